"""The operator console: a viser app that talks to the robot only through the link."""
