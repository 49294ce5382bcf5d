"""The committed suite's top groups do not depend on the bootstrap's seed: every tier's top group, ranked as
``suite.md`` ranks it from ``results/suite_episodes.csv``, is the same under other seeds."""

from __future__ import annotations

import pytest

from agents.common.locations import RESULTS_DIR
from agents.common.seeds import SUITE_LAYOUTS, suite_seeds
from agents.evaluation.suite import (
    EPISODES_CSV,
    agent_runs,
    suite_agents,
    suite_rows,
    suite_tasks,
    summarise_suite,
)
from agents.evaluation.suite_ranking import rank_suite, tier_failures
from flownav_env.tiers import SUITE_VERSION, TIER_NAMES

OTHER_SEEDS = range(1, 5)


@pytest.mark.slow
def test_the_committed_suites_top_groups_are_the_same_under_other_bootstrap_seeds() -> None:
    path = RESULTS_DIR / EPISODES_CSV
    if not path.is_file():
        pytest.skip(f"no committed suite episodes at {path}")
    runs = {agent: agent_runs(agent) for agent in suite_agents(SUITE_VERSION)}
    tasks = [
        task
        for agent, names in runs.items()
        for task in suite_tasks({agent: names}, TIER_NAMES, SUITE_LAYOUTS, version=SUITE_VERSION)
    ]
    rows = suite_rows(tasks, path)
    table = summarise_suite(rows, runs, TIER_NAMES, SUITE_LAYOUTS, SUITE_VERSION)
    layouts = list(suite_seeds(SUITE_LAYOUTS, SUITE_VERSION))
    failures = {name: tier_failures(rows, runs, name, layouts) for name in TIER_NAMES}
    published = {name: ranking.top_group for name, ranking in rank_suite(table, failures).items()}
    assert set(published) == set(TIER_NAMES)
    for seed in OTHER_SEEDS:
        groups = {name: ranking.top_group for name, ranking in rank_suite(table, failures, seed).items()}
        assert groups == published, f"bootstrap seed {seed}"
