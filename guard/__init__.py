"""Who may talk to our servers, and what a request body may be: one place for each rule.

A leaf package (it imports nothing of ours), so the robot server, the link proxy and the
console apply the same Host, Origin, token and JSON rules.
"""
