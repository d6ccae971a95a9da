"""The rod-in-channel engine: a source cable pushed through an applicator channel."""
