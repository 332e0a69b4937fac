"""The robot client runtime: pure basis behaviours, arbitration, tasks and the robot agent.

Each robot is its own process (`murdoch-robot`, see `behaviors.__main__`) that talks to its
robot only through `player_server.client`. The pieces, from the inside out:

- `snapshot`: frozen per-tick sensor views; `proposal`: what a behaviour wants;
- `basis`: the basis behaviours, each a pure `decide(snapshot, now) -> Proposal`;
- `contract`: the checker every behaviour passes;
- `arbiter`, `task`, `library`, `metrics`: tasks as staged compositions of behaviours, with
  resource subjects and metric functions;
- `battery`: the charging state machine; `runner`: one thread per behaviour;
- `agent`: `RobotAgent`, the control loop and the API an auction layer drives;
- `sensing`, `robot`: the Player side (`build_agent(client, name, world=...)`).
"""
