"""Recordings of runs as MCAP files: the channels (`channels`), a writer that owns its own
thread (`writer`) and a reader that survives a file cut short (`reader`).

Pure of the simulator and of Player: the experiment runner fills the channels from its
simulation, `player_server.replay` serves them back over Player, and Foxglove opens them.
"""
