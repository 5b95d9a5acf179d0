#!/usr/bin/env python3
from roks_tools.studies.gold_sphere import main; raise SystemExit(main())  # noqa: E702 (see python/roks_tools)
