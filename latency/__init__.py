"""The link: a clock-independent FIFO delay line, link profiles, and an HTTP + WebSocket proxy.

Depends only on guard, recording's writer and ptwl_config, all below it (docs/architecture.md).
"""
