"""The batched game: court, shuttle flight, rules and bodies. Knows nothing of Gymnasium."""
