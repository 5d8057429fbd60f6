"""Thin API views over the batched game: Gymnasium (single and vector) and PettingZoo, one module
per game."""
