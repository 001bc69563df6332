"""``python -m rail_mj.dataset``: generate the procedural dataset or fetch the real-mesh set."""

from rail_mj.dataset.cli import main

raise SystemExit(main())
