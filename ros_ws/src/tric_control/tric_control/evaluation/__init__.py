"""Evaluation episodes and their records: the records and tables (records), the episodes through
the real nodes (graph) and offline (offline), evaluations kept on disk (kept), and where parallel
episodes and trainings run (executors, workers, ray_executor, shipped_files)."""
