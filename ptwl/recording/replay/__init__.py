"""A recording read for replay: its timeline (bounded memory) and the player's clock; the robot
that serves it is server/replay/."""
