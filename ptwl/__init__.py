"""The whole system from one command line: `ptwl up|serve|proxy|console|sim`, and the launcher
that starts the robot server, the link and the console as child processes."""
