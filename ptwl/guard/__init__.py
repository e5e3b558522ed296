"""Who may talk to our servers, and what a request body may be: one place for each rule.

Next to the bottom of the house (it imports only ptwl_config, for the project's root error), so
the robot server, the link proxy and the console apply the same Host, Origin, token and JSON
rules.
"""
