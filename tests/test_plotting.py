"""pkmlib.plotting.save_figure: the arrays beside a figure and the text-size record."""

import hashlib
import time

import numpy as np
import pytest
from PIL import Image

from pkmlib.plotting import plt, save_figure, smallest_text_pt


def test_arrays_saved_beside_png_identically(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    arrays = {"x_D_m": np.linspace(0, 1, 3), "v_max_m_s": np.array([[1.0, np.nan], [2.0, 3.0]])}
    digests = []
    for _ in range(2):
        save_figure(fig, tmp_path / "f.png", source="test", arrays=arrays)
        digests.append(hashlib.sha256((tmp_path / "f.npz").read_bytes()).hexdigest())
        time.sleep(1.1)  # zip timestamps have 2 s resolution: a clock-stamped file would differ
    plt.close(fig)
    assert digests[0] == digests[1]
    with np.load(tmp_path / "f.npz") as z:
        assert sorted(z.files) == ["v_max_m_s", "x_D_m"]
        np.testing.assert_array_equal(z["v_max_m_s"], arrays["v_max_m_s"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.npz", "f.png"]


def test_min_text_px_recorded(tmp_path):
    fig, ax = plt.subplots()
    ax.set_title("small", fontsize=7)
    ax.set_xlabel("x", fontsize=12)
    assert smallest_text_pt(fig) == 7.0
    path = save_figure(fig, tmp_path / "g.png", source="t")
    plt.close(fig)
    assert float(Image.open(path).info["MinTextPx"]) == pytest.approx(7 * 150 / 72, abs=0.05)


@pytest.mark.parametrize(
    "arrays, match",
    [({}, "non-empty"), ({"a b": [1.0]}, "identifiers"), ({"x": ["a"]}, r"arrays\['x'\]"), ([1, 2], "mapping")],
)
def test_bad_arrays_refused(tmp_path, arrays, match):
    fig, _ = plt.subplots()
    with pytest.raises(ValueError, match=match):
        save_figure(fig, tmp_path / "f.png", source="t", arrays=arrays)
    plt.close(fig)
    assert not (tmp_path / "f.npz").exists()
