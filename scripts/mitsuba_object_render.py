#!/usr/bin/env python3
from roks_tools.mitsuba.object_render import main; raise SystemExit(main())  # noqa: E702 (see python/roks_tools)
