"""The tests run as strictly as equinox's: rank promotion and implicit dtype promotion are errors,
here and in the Python processes tests start; warnings from pkmlib are errors."""

import subprocess
import sys
import warnings

import jax.numpy as jnp
import numpy as np
import pytest


def test_rank_and_dtype_promotion_raise_in_the_tests():
    with pytest.raises(ValueError, match="jax_numpy_rank_promotion='raise'"):
        jnp.ones(3) + jnp.ones((2, 3))
    with pytest.raises(Exception, match="jax_numpy_dtype_promotion=strict"):
        jnp.ones(3, dtype=jnp.float32) + jnp.ones(3, dtype=jnp.int32)
    assert (jnp.ones(3) + 1.0).dtype == jnp.float64


def test_processes_started_by_tests_are_as_strict():
    code = (
        "import jax.numpy as jnp\n"
        "try:\n    jnp.ones(3) + jnp.ones((2, 3))\nexcept ValueError as e:\n    print('raised', 'jax_numpy_rank_promotion' in str(e))\n"
        "print(jnp.ones(2).dtype)"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["raised", "True", "float64"]


def test_a_warning_from_pkmlib_is_an_error():
    import pkmlib

    code = compile("warnings.warn('from pkmlib', UserWarning)", "pkmlib_module", "exec")
    with pytest.raises(UserWarning):
        exec(code, {"warnings": warnings, "__name__": "pkmlib._example"})
    assert pkmlib is not None and np.isfinite(1.0)
