"""Issue 18.2: YAML given to a re-run (``-y`` text, ``-f`` file, a bracketed ``-p`` value) is read
safely: limits on size and alias expansion, duplicate keys refused naming the key, only plain data
(numbers, text, true/false, null, lists, mappings), empty values reported as empty, binary or
undecodable files refused naming the file.

Every refusal comes from the entry point in this process, before any kernel starts (exit status
2, a short message on stderr); ``execute`` is replaced by a function that fails the test.
"""

import datetime
import json

import nbformat
import pytest

from pkmlib import _safe_yaml
from pkmlib.tools import rerun


def billion_laughs(levels: int = 9, width: int = 9) -> str:
    """``levels`` anchors, each a list of ``width`` aliases of the one before: ``width ** levels``
    strings once expanded, in a few hundred bytes (issue 18: 436 bytes grew past 3.7 GB)."""
    lines = ['a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        lines.append(f"{chr(97 + i)}: &{chr(97 + i)} [" + ", ".join([f"*{chr(96 + i)}"] * width) + "]")
    return "\n".join(lines) + "\n"


def nested_laughs(levels: int) -> str:
    """The same as one parameter's value (so the notebook's names check lets it through)."""
    items = ['&a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        items.append(f"&{chr(97 + i)} [" + ", ".join([f"*{chr(96 + i)}"] * 9) + "]")
    return "x_m: [" + ", ".join(items) + "]\n"


@pytest.fixture
def toy(tmp_path, monkeypatch):
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(
            'x_m = 1.0\nlabel = "a"\nbranch = [1, -1]\nresults_path = "r.json"', metadata={"tags": ["parameters"]}
        )
    ]
    path = tmp_path / "notebooks" / "toy.ipynb"
    path.parent.mkdir()
    nbformat.write(nb, path)

    def never(run, kernel):
        raise AssertionError(f"executed with {run.given}")

    monkeypatch.setattr(rerun, "execute", never)
    monkeypatch.chdir(tmp_path)
    return path


def refused(capsys, nb, *argv):
    """The stderr of a re-run that must stop before anything runs (status 2, nothing written)."""
    status = rerun.main([str(nb), *argv])
    err = capsys.readouterr().err
    assert status == 2, err
    assert not (nb.parent.parent / "runs").exists()
    return err


# ---------------------------------------------------------------- size and alias expansion


def test_a_billion_laughs_file_is_refused_at_once_with_a_short_message(toy, tmp_path, capsys):
    f = tmp_path / "laughs.yaml"
    f.write_text(billion_laughs())
    assert len(f.read_bytes()) < 500
    err = refused(capsys, toy, "-f", str(f))
    assert err == f"error: -f {f}: more than 10000 values once its aliases (*name) are expanded (line 5)\n"


def test_aliases_expanding_in_one_parameter_are_refused(toy, capsys):
    # issue 18: a 385-byte file took 29 s and printed a 122 MB error (the value's repr)
    err = refused(capsys, toy, "-y", nested_laughs(6))
    assert err.startswith("error: -y: more than 10000 values once its aliases (*name) are expanded")
    assert len(err) < 200


def test_few_aliases_are_accepted():
    assert _safe_yaml.load("a: &r [0.2, 1.2]\nb: *r\n", "-y") == {"a": [0.2, 1.2], "b": [0.2, 1.2]}


@pytest.mark.parametrize(
    "text, problem",
    [
        ("x_m: &a [*a]", "a value that contains itself"),
        ("x_m: " + "[" * 40 + "]" * 40, "nested deeper than 32 levels"),
        (
            "x_m: &a [[[[[[[[1]]]]]]]]\n"
            + "".join(f"k{i}: &k{i} [*{'a' if i == 0 else f'k{i - 1}'}]\n" for i in range(30)),
            "nested deeper than 32 levels once",
        ),
    ],
)
def test_self_containing_and_deeply_nested_values_are_refused(text, problem):
    with pytest.raises(rerun.RerunError, match=problem):
        rerun.given_parameters(rerun.parse_arguments(["toy", "-y", text]))


def test_a_file_over_the_size_limit_is_refused_without_reading_it_all(toy, tmp_path, capsys):
    f = tmp_path / "big.yaml"
    f.write_text("x_m: 1\n" + "# comment\n" * 20_000)
    err = refused(capsys, toy, "-f", str(f))
    assert err == f"error: -f {f}: larger than 100000 bytes (parameters take a few hundred)\n"
    assert "larger than" in refused(capsys, toy, "-y", "x_m: 1 " + " " * 100_000)


# ---------------------------------------------------------------- duplicate keys


@pytest.mark.parametrize(
    "text, key, lines",
    [
        ("x_m: 25\nx_m: 30\n", "'x_m'", "1 and 2"),  # issue 18: ran at 30 without a warning
        ("x_m: 2\nlabel: b\n'x_m': 3\n", "'x_m'", "1 and 3"),
        ("x_m: 2\nbranch: {a: 1, a: 2}\n", "'a'", "2 and 2"),
    ],
)
def test_a_duplicate_key_is_refused_naming_it(toy, tmp_path, capsys, text, key, lines):
    err = refused(capsys, toy, "-y", text)
    assert err == f"error: -y: duplicate key {key} (lines {lines}): give each key once\n"
    f = tmp_path / "p.yaml"
    f.write_text(text)
    assert f"-f {f}: duplicate key {key}" in refused(capsys, toy, "-f", str(f))


def test_a_duplicate_key_in_a_bracketed_p_value_is_refused(toy, capsys):
    err = refused(capsys, toy, "-p", "branch", "{a: 1, a: 2}")
    assert "duplicate key 'a'" in err


# ---------------------------------------------------------------- only plain data


@pytest.mark.parametrize(
    "text, tag",
    [
        ("x_m: !!python/object/apply:os.system ['echo hi']", "!!python/object/apply:os.system"),
        ("x_m: !!python/name:os.system ''", "!!python/name:os.system"),
        ("label: !!set {a, b}", "!!set"),
        ("label: !!binary aGVsbG8=", "!!binary"),
        ("label: !!timestamp 2024-01-01", "!!timestamp"),
        ("label: !!omap [a: 1]", "!!omap"),
        ("label: !custom 1", "!custom"),
    ],
)
def test_anything_but_plain_data_is_refused_naming_the_tag(toy, capsys, text, tag):
    err = refused(capsys, toy, "-y", text)
    assert err == (
        f"error: -y: the tag {tag} is not accepted: only numbers, text, true/false, null, lists and mappings (line 1)\n"
    )


@pytest.mark.parametrize(
    "text, problem",
    [
        ("base: &b {x_m: 2}\n<<: *b\n", "a merge key (<<) is not accepted"),
        ("? [1, 2]\n: 3\n", "a list or mapping used as a key"),
    ],
)
def test_merge_keys_and_complex_keys_are_refused(toy, capsys, text, problem):
    assert problem in refused(capsys, toy, "-y", text)


def test_dates_are_text_and_exponents_are_numbers():
    # decided: no date objects (they are not plain data); as on a command line, a date is text
    text = "label: 2024-01-01\nt: 2024-01-01 10:00:00\nx: 2.5e-5\ny: 1e3\nz: =\n"
    data = rerun.given_parameters(rerun.parse_arguments(["toy", "-y", text]))
    assert data == {"label": "2024-01-01", "t": "2024-01-01 10:00:00", "x": 2.5e-5, "y": 1000.0, "z": "="}
    assert not any(isinstance(v, (datetime.date, datetime.datetime)) for v in data.values())


def test_parameter_names_must_be_text(toy, capsys):
    assert refused(capsys, toy, "-y", "1: 2") == "error: -y: parameter names are text, got 1\n"


# ---------------------------------------------------------------- empty values


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["-y", "x_m:"],
            "-y: 'x_m' has an empty value (line 1): write its value, or leave 'x_m' out for the paper's value",
        ),
        (["-y", "label: a\nx_m:\n"], "-y: 'x_m' has an empty value (line 2)"),
        (
            ["-y", "branch: [1, -1]\nx_m: {a: }\n"],
            "-y: an empty value: write the value (or null), or leave the key out (line 2)",
        ),
        (["-y", "branch:\n  - 1\n  -\n"], "-y: an empty value"),
        (["-p", "x_m", ""], "-p x_m: an empty value; write its value, or leave x_m out for the paper's value"),
        (["-p", "x_m", "  "], "-p x_m: an empty value"),
        (["-y", ""], "-y: empty (no parameters in it); write 'name: value' lines"),
        (["-y", "# only a comment"], "-y: empty (no parameters in it)"),
    ],
)
def test_an_empty_value_is_reported_as_empty_not_as_none(toy, capsys, argv, message):
    # issue 18: an empty value was reported as None
    err = refused(capsys, toy, *argv)
    assert err.startswith(f"error: {message}") and "None" not in err


def test_an_empty_file_is_reported_as_empty(toy, tmp_path, capsys):
    f = tmp_path / "empty.yaml"
    f.write_text("")
    assert refused(capsys, toy, "-f", str(f)) == (
        f"error: -f {f}: empty (no parameters in it); write 'name: value' lines\n"
    )


def test_null_written_out_is_null_and_quotes_give_empty_text():
    assert _safe_yaml.load("a: null\nb: ~\nc: ''\n", "-y") == {"a": None, "b": None, "c": ""}


# ---------------------------------------------------------------- files that are not YAML text


@pytest.mark.parametrize(
    "content, message",
    [
        (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "a binary file, not YAML text (it holds NUL bytes)"),
        (b"x_m: caf\xe9\n", "not UTF-8 text (byte 0xe9 at offset 8): a binary file?"),
        (b"\xff\xfex\x00", "a binary file, not YAML text (it holds NUL bytes)"),
    ],
)
def test_a_binary_or_undecodable_file_is_refused_naming_it(toy, tmp_path, capsys, content, message):
    # issue 18: a binary -f file ended in a raw traceback
    f = tmp_path / "figure.png"
    f.write_bytes(content)
    assert refused(capsys, toy, "-f", str(f)) == f"error: -f {f}: {message}\n"


def test_a_utf8_file_with_a_byte_order_mark_is_read(toy, tmp_path):
    f = tmp_path / "p.yaml"
    f.write_bytes("\ufefflabel: é\n".encode())
    assert rerun.given_parameters(rerun.parse_arguments(["toy", "-f", str(f)])) == {"label": "é"}


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda p: p.mkdir(), "a folder, not a file"),
        (lambda p: None, "no such file"),
    ],
)
def test_f_that_is_a_folder_or_missing_is_refused_naming_it(toy, tmp_path, capsys, make, message):
    p = tmp_path / "params"
    make(p)
    assert refused(capsys, toy, "-f", str(p)) == f"error: -f {p}: {message}\n"


def test_control_characters_are_refused_as_not_yaml(toy, capsys):
    err = refused(capsys, toy, "-y", "x_m: 1\x07")
    assert err.startswith("error: -y: not valid YAML: unacceptable character #x0007") and len(err) < 200


def test_yaml_syntax_errors_are_one_short_line(toy, capsys):
    err = refused(capsys, toy, "-y", "x_m: [1")
    assert err == "error: -y: not valid YAML: expected ',' or ']', but got '<stream end>' (line 1, column 8)\n"


def test_the_loader_returns_only_plain_python_values():
    data = _safe_yaml.load("a: [1, 2.5, true, null, text, {b: [c]}]\n", "-y")
    assert json.loads(json.dumps(data)) == data
