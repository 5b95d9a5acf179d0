#!/usr/bin/env python3
from roks_tools.studies.radiator_spectral import main; raise SystemExit(main())  # noqa: E702 (see python/roks_tools)
