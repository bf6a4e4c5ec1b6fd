from simcalib.cli import main

raise SystemExit(main())
