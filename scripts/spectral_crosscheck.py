#!/usr/bin/env python3
from roks_tools.studies.spectral_crosscheck import main; raise SystemExit(main())  # noqa: E702 (see python/roks_tools)
