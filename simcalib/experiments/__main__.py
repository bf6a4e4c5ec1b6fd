from simcalib.experiments import main

raise SystemExit(main())
