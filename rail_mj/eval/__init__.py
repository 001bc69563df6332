"""Evaluation: run a labelled dataset, summarise it into the paper's tables, report and merge runs."""
