"""Onboard state machines written as data (spec.py), run by one engine (engine.py); the
built-in ones are files (library.py, builtin/*.toml)."""
