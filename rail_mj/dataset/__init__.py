"""Datasets: labels, ground truth, the procedural shapes and dataset, the real-mesh development set."""
