"""The link: a clock-independent FIFO delay line, link profiles, and an HTTP + WebSocket proxy.

Depends on nothing else of ours (ARCHITECTURE.md).
"""
