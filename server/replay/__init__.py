"""`ptwl replay`'s robot: a recording served read-only through the robot's own API (the reading
and the clock are recording/replay/'s)."""
