"""Policies the runner drives: the common interface, in-process callables, openpi websocket servers, the scripted oracle, reference policies."""
