"""`iguana run`'s process supervisor, on the floor above nodes and bag: starts the recorder and the node processes
(`run`), guards them (`process`, `domain_check`) and reports from the bag (`run_summary`, `run_gait`)."""
