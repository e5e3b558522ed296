"""Session recordings in MCAP: written by the Foxglove SDK, read back with the `mcap` reader.

topics.py names every channel and its schema; writer.py records a session (the robot server,
a sweep trial, the link); reader.py reads a file back, a cut-short one too; report.py gives a
recording's per-trial figures; replay/ serves a recording to the console as if it were live.
"""
