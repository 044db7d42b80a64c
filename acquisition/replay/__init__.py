"""Recorded sessions (and frame stacks) played back through the engine, in the console and in
batch."""
