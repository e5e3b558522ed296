"""`ptwl replay`: a recording served to the console as if it were the robot."""
