"""`ptwl replay`'s robot: a recording served read-only through the robot's own API (the reading
and the clock are ptwl/recording/replay/'s)."""
