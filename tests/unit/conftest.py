"""The unit tests that `make test-fast` leaves out (marked ``slow``).

Each takes seconds, not milliseconds: the compiled allocators compared against the agents on
hundreds of scenarios, refinement measured on seeded sets, property tests of the wire's fast
path, recordings written by processes, plots, and one process that compiles a kernel from a
cold cache. `make test` runs them all; `make test-fast` runs the rest.
"""

from __future__ import annotations

import pytest

SLOW = frozenset({
    "test_allocators_consensus_refine.py::test_refined_tasks_arriving_over_time_are_each_done_once",
    "test_code_size.py::test_no_module_class_or_function_is_over_its_limit",
    "test_consensus_async_refine.py::test_refine_over_the_bus_with_loss",
    "test_consensus_cbga_fastpath.py::test_bench_scenarios_identical",
    "test_consensus_cbga_fastpath.py::test_final_bids_identical",
    "test_consensus_cbga_fastpath.py::test_formerly_cycling_quitting_runs_identical",
    "test_consensus_cbga_fastpath.py::test_random_scenarios_identical",
    "test_consensus_cbga_fastpath.py::test_random_scenarios_identical_with_the_paper_cost",
    "test_consensus_cbga_fastpath.py::test_recorded_experiments_identical",
    "test_consensus_cbga_fastpath.py::test_recorded_experiments_identical_with_the_paper_cost",
    "test_consensus_cli.py::test_allocate_says_it_compiles_when_the_cache_is_cold",
    "test_consensus_exact.py::test_exact_equals_brute_force_on_tiny_problems",
    "test_consensus_fastpath.py::test_bench_scenarios_identical",
    "test_consensus_fastpath.py::test_random_scenarios_identical",
    "test_consensus_gains.py::test_list_resolution_matches_the_table",
    "test_consensus_gains.py::test_pruned_cbba_equals_full_evaluation_on_random_scenarios",
    "test_consensus_paper_cost.py::test_pruned_bundles_equal_full_evaluation",
    "test_consensus_refine.py::test_refine_fills_a_group_task_plain_cbga_misses",
    "test_consensus_refine.py::test_refine_is_conflict_free_feasible_and_never_worse",
    "test_consensus_refine_opening.py::test_targets_on_a_fixed_seeded_set",
    "test_consensus_refine_opening.py::test_the_agent_alone_bounds_change_no_move",
    "test_consensus_refine_opening.py::test_the_opening_saves_the_paths_round",
    "test_consensus_refine_pairs.py::test_a_fast_converging_group_run_stays_within_half_again",
    "test_consensus_refine_pairs.py::test_messages_stay_within_half_again_the_plain_run_at_ten_agents",
    "test_consensus_refine_pairs.py::test_pairs_raise_the_worst_case_over_one_task_moves",
    "test_experiments_summary.py::test_plots_are_written",
    "test_experiments_summary.py::test_plots_of_an_empty_run",
    "test_experiments_sweep_longterm.py::test_rows_scale_to_three_hours_and_average_over_seeds",
    "test_murdoch_stateful.py::TestAuctionInvariants::runTest",
    "test_murdoch_wire_fastpath.py::test_compact_announcements_decode_as_the_json_decoder_decodes_them",
    "test_murdoch_wire_fastpath.py::test_compact_bodies_are_written_as_the_json_encoder_writes_them",
    "test_murdoch_wire_fastpath.py::test_compact_bodies_decode_as_the_json_decoder_decodes_them",
    "test_record_files.py::test_a_file_cut_short_reads_up_to_its_last_whole_chunk",
    "test_record_files.py::test_a_writer_that_dies_stops_the_recording_not_the_recorder",
    "test_record_files.py::test_the_observer_comes_back_and_what_cannot_travel_is_counted",
    "test_record_files.py::test_the_writer_finishes_the_file_when_the_recording_process_dies",
    "test_record_files.py::test_threads_that_record_at_once_lose_nothing",
    "test_record_files.py::test_write_and_read_back",
    "test_worlds_generate.py::test_a_bad_generated_world_is_reported_without_a_traceback",
    "test_worlds_generate.py::test_same_seed_same_world_and_other_seeds_differ",
})


def _key(item: pytest.Item) -> str:
    """module file::test (class::test for a test class), without parameters."""
    parts = item.nodeid.split("::")
    parts[0] = parts[0].rsplit("/", 1)[-1]
    parts[-1] = parts[-1].split("[", 1)[0]
    return "::".join(parts)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if _key(item) in SLOW:
            item.add_marker(pytest.mark.slow)
