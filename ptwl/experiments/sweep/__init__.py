"""Latency sweeps: a task at several round trips, operated from the ground (move-and-wait through
the delayed link) or onboard (one state-machine command), in virtual time.

spec.py      a trial's settings and the grid of trials
robot.py     the robot side: a Simulation running commands by the server's rules
operators.py the ground and onboard operators (clock-free: `now` comes in)
trial.py     one trial: robot, link and operator on one simulated clock; its CSV row
table.py     the CSV's columns, reading and writing rows (resume, sorted rewrite)
summary.py   the paper's Tables 1-3 rows per (operator, RTT); fits and break-even
plots.py     report.md and its PNGs (matplotlib)
backends.py  a local process pool or Ray
sweep.py     the whole sweep: grid, resume, progress, outputs
realtime.py  one grid point through the real `ptwl serve` and `ptwl proxy`
"""
