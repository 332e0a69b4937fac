"""The team-member contract, implemented once for every allocator (pure rules).

However an allocator decides who executes a task (MURDOCH's auctions, CBBA's and CBGA's
consensus, a central `murdoch.plugin.CentralAllocator`), the user that introduced the task
and the robot that executes it then keep the same contract; its rules live here and the
allocators call them (`murdoch.auction`, `murdoch.allocators.consensus_*`,
`murdoch.execution.central_*`). The members that grant over the bus also share their shells:
`bus_member` (the step skeleton, closing, sending), `task_user` (the user: introduces tasks,
executes none, and the user's side of the contract) and `task_robot` (a robot: executes what
it is granted, introduces nothing, and the executor's side):

1. **Offer or grant.** Each attempt to allocate a task (at most `TaskSpec.max_attempts`,
   `user_side.next_attempt`) ends with exactly one executor granted the task, or none.
2. **No executor.** An attempt that finds none within its bid window is retried after the
   user's randomized backoff while the task's patience lasts; then the task is
   `unachievable` (`user_side.no_winner`).
3. **Renewals.** The user repeats its grant every `renew_period_s` (`user_side.Lease`); an
   executor that hears no renewal for `abandon_after_s` gives the task up and says so
   (`executor.Execution`).
4. **Progress.** The executor reports progress at least every renewal period (in answer to a
   renewal, or on its own clock); every report keeps the grant alive.
5. **Revocation of a silent executor.** An executor not heard for `contract_timeout_s` is
   revoked, and the task is offered again only after `abandon_after_s`, when the silent robot
   has given it up, so two robots never execute it at once.
6. **End reports.** Completed and failed end the task; abandoned or declined put it up again at
   once (`user_side.on_report`). The executor keeps its end reports and sends one again each
   time it hears the user still renew that grant (the first was lost) (`executor.EndReports`).
7. **Timeout.** A task granted longer than its `timeout_s` fails.
8. **One outcome.** Every task ends with exactly one `Outcome` (completed, failed or
   unachievable; `user_side.outcome`), reported to the user's observer as an `outcome` event.

The timings come from the task (`TaskSpec`: `bid_window_s`, `renew_period_s`,
`contract_timeout_s`, `abandon_after_s`, `timeout_s`; `murdoch.auction.timing`).
"""
