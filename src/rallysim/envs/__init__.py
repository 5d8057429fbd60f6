"""Thin API views over the batched game: Gymnasium (single and vector) and, later, PettingZoo."""
