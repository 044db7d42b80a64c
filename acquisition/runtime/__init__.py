"""The live session: device threads, frame rings, the time base and the range histories."""
