"""``python -m rail_mj.eval``: the paper's Table 1 and Table 2 on a labelled dataset."""

from rail_mj.eval.cli import main

raise SystemExit(main())
