"""The field's formats: a split as Hugging Face ``datasets`` Parquet (:mod:`.hf`), as a
LeRobot v3.0 dataset (:mod:`.lerobot`), and its Croissant metadata (:mod:`.croissant`)."""
