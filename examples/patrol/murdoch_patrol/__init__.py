"""Patrolling waypoints: an example of a murdoch plugin package.

It adds, through entry points, a task kind (``patrol-waypoints``: drive a loop of waypoints
for a while), an experiment (``patrol``: patrol routes arrive at random) and a centralised
allocator (``nearest-patroller``: each route to the free robot nearest its first waypoint).
"""
