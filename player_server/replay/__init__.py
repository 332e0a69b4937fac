"""Serving a run recording back over the Player protocol, as Player's readlog does.

`RecordedRun` reads ``run.mcap`` forward in time, `ReplayClock` is the `Steppable` the
Player server steps, `drivers` turn the latest recorded message of each device into Player
DATA, and `serve.main` is ``player-server --replay``.
"""
