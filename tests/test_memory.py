"""The size guard: work whose estimated memory exceeds the budget fails before it starts, naming
the parameter that sets its size (issue 11: P2 `step_m 2.5e-5` asks for ~7e8 points)."""

import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib import _memory


def p2_grid(step_m):
    """P2's map grid (notebook defaults) at step ``step_m``."""
    return pk.Grid.from_ranges(x_P=(-0.15, 0.55, step_m), y_P=(-0.15, 0.5, step_m))


def three_numbers(point):
    return jnp.stack([point[0], point[1], point[0] * point[1]])


def test_p2_step_typo_fails_at_once_naming_step_m(monkeypatch):
    monkeypatch.setenv(_memory.BUDGET_ENV, "4e9")
    grid = p2_grid(2.5e-5)
    assert grid.size > 7e8
    with pytest.raises(
        pk.MemoryBudgetError,
        match=r"a sweep of 7\.\d+e\+08 points .* needs about 1\d\.\d GiB, "
        r"set by step_m: more than the memory budget of 3.73 GiB",
    ):
        pk.sweep(three_numbers, grid, size_parameter="step_m")


def test_the_error_is_a_value_error_and_a_memory_error():
    with pytest.raises(ValueError, match="set by step_m"):
        pk.check_memory(2e9, what="a sweep", parameter="step_m", budget=1e9)
    assert issubclass(pk.MemoryBudgetError, MemoryError)


def test_the_papers_grid_fits_and_gives_the_same_numbers_with_and_without_a_budget():
    grid = p2_grid(0.05)
    a = pk.sweep(three_numbers, grid, size_parameter="step_m", memory_budget=1e6)
    b = pk.sweep(three_numbers, grid)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(pk.MemoryBudgetError, match=r"set by step_m.*\(the memory_budget given\)"):
        pk.sweep(three_numbers, grid, size_parameter="step_m", memory_budget=float(a.nbytes) - 1)
    # the results of the calls in flight count too (here every call: one window)
    with pytest.raises(pk.MemoryBudgetError, match="set by step_m"):
        pk.sweep(three_numbers, grid, size_parameter="step_m", memory_budget=2.0 * a.nbytes - 1)
    np.testing.assert_array_equal(pk.sweep(three_numbers, grid, memory_budget=2.0 * a.nbytes), b)


def test_a_simulation_too_long_names_its_time_step():
    n_steps = 0.3 / 1e-12
    with pytest.raises(pk.MemoryBudgetError, match=r"a simulation of 3e\+11 steps needs about .* set by sim_dt_s"):
        pk.check_memory(n_steps * 13 * 8, what=f"a simulation of {n_steps:.3g} steps", parameter="sim_dt_s")


def test_the_budget_defaults_to_half_the_machine_and_can_be_overridden(monkeypatch):
    monkeypatch.delenv(_memory.BUDGET_ENV, raising=False)
    assert pk.memory_budget() == int(0.5 * _memory.machine_memory())
    with pytest.raises(pk.MemoryBudgetError, match=r"0.5 of this machine's .* set \$PKMLIB_MEMORY_BUDGET"):
        pk.check_memory(_memory.machine_memory(), what="everything")
    monkeypatch.setenv(_memory.BUDGET_ENV, "2e9")
    assert pk.memory_budget() == 2_000_000_000
    assert pk.memory_budget(1e6) == 1_000_000  # an explicit budget wins over the environment
    pk.check_memory(1.9e9, what="a sweep")  # within the budget: nothing happens
    with pytest.raises(pk.MemoryBudgetError, match=r"\(\$PKMLIB_MEMORY_BUDGET\)"):
        pk.check_memory(2.1e9, what="a sweep")


@pytest.mark.parametrize("env", ["lots", "-1", "0"])
def test_a_bad_budget_is_named(monkeypatch, env):
    monkeypatch.setenv(_memory.BUDGET_ENV, env)
    with pytest.raises(ValueError, match="PKMLIB_MEMORY_BUDGET|memory_budget"):
        pk.memory_budget()


def test_a_nan_size_fails():
    with pytest.raises(pk.MemoryBudgetError):
        pk.check_memory(float("nan"), what="a sweep", parameter="step_m", budget=1e9)
