"""What flows between threads, on the common monotonic clock: the preallocated frame ring (one
producer, readers that never block it), the short histories of readings a frame's range is
interpolated from, and the map from the monotonic clock to UTC."""
