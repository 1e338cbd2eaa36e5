"""Bad mechanism descriptions give a ValueError naming the body, joint or key and what is accepted
(issue 19 item 8), never a silent mechanism."""

import copy

import pytest
import yaml

import pkmlib as pk

DESC = pk.DATA_DIR / "mechanisms"


def _base(name="p2_three_rrr"):
    return yaml.safe_load((DESC / f"{name}.yaml").read_text(encoding="utf-8"))


def _joint(d, name):
    return next(j for j in d["joints"] if j["name"] == name)


def _fails(d, *fragments):
    with pytest.raises(ValueError) as e:
        pk.load_mechanism(d)
    msg = str(e.value)
    for f in fragments:
        assert f in msg, f"{f!r} not in: {msg}"
    return msg


def test_the_unmodified_descriptions_load():
    assert pk.load_mechanism(_base()).n_actuators == 3
    assert pk.load_mechanism(_base("p4_five_bar")).n_actuators == 2


# --------------------------------------------------------------------------- joint types
def test_unknown_joint_type_names_the_joint_and_the_accepted_types():
    d = _base()
    _joint(d, "B2")["type"] = "helical"
    _fails(d, "joint 'B2'", "unknown joint type 'helical'", "revolute, prismatic, universal, spherical, fixed")


def test_spatial_joint_in_a_planar_mechanism():
    d = _base()
    _joint(d, "C1")["type"] = "spherical"
    _fails(d, "joint 'C1'", "not a planar joint", "revolute, prismatic, fixed")


def test_actuated_point_joint_and_missing_variable():
    d = _base("p3_mechanism_a")
    _joint(d, "C1")["actuated"] = True
    _joint(d, "C1")["variable"] = "c"
    _fails(d, "joint 'C1'", "only a revolute or prismatic joint can be actuated, not a universal")
    d = _base()
    del _joint(d, "A1")["variable"]
    _fails(d, "joint 'A1'", "needs a 'variable'")


# --------------------------------------------------------------------------- loops
def test_a_loop_that_skips_a_joint_does_not_close():
    d = _base()
    d["loops"][1] = ["A2", "C2"]
    _fails(d, "loops[1]", "does not close", "joint 'C2'", "'crank_2'")


def test_a_loop_that_stops_before_the_output_does_not_close():
    d = _base()
    d["loops"][0] = ["A1", "B1"]
    _fails(d, "loops[0]", "does not close", "ends at body 'link_1'", "platform")


def test_a_loop_that_does_not_start_at_the_base():
    d = _base()
    d["loops"][2] = ["B3", "C3"]
    _fails(d, "loops[2]", "does not close", "joint 'B3'", "'base'")


def test_an_element_in_no_loop():
    d = _base()
    del d["loops"][2]
    _fails(d, "link_3", "in no loop")


def test_a_loop_naming_an_unknown_joint():
    d = _base()
    d["loops"][0] = ["A1", "B1", "C9"]
    _fails(d, "loops[0]", "unknown joint 'C9'")


def test_a_body_that_is_not_a_connecting_element():
    d = _base()
    d["bodies"].append("extra")
    d["joints"].append({"name": "X", "type": "revolute", "parent": "link_1", "child": "extra", "at": [0.1, 0]})
    _fails(d, "link_1", "not a connecting element")


# --------------------------------------------------------------------------- mobility
def test_gruebler_kutzbach_disagreeing_with_the_outputs():
    d = _base("p4_five_bar")
    del d["output"]["point"]
    d["output"]["rotation"] = 0  # the point C drawn as a body that keeps its orientation: its spin counts
    _fails(
        d,
        "Gruebler-Kutzbach mobility M = 3 (6 - 1 - 6) + 6 - 0 (idle) + 0 (overconstraints) = 3",
        "2 output coordinate(s)",
    )


def test_gruebler_kutzbach_with_a_wrong_overconstraint_count():
    d = _base()
    d["overconstraints"] = {"count": 1, "why": "none really"}
    _fails(d, "Gruebler-Kutzbach", "= 4 disagrees with the 3 output coordinate(s)")
    d["overconstraints"] = 1
    _fails(d, "overconstraints", "needs its 'why'")


def test_an_actuator_too_many():
    d = _base()
    _joint(d, "B1")["actuated"] = True
    _joint(d, "B1")["variable"] = "beta_1"
    _fails(d, "joint 'C1'", "directly to the output side", "wrongly actuated")


# --------------------------------------------------------------------------- names
def test_duplicate_joint_body_and_parameter_names(tmp_path):
    d = _base()
    _joint(d, "B2")["name"] = "B1"
    _fails(d, "joint 'B1'", "duplicate joint name 'B1'")
    d = _base()
    d["bodies"].append("link_1")
    _fails(d, "bodies[7]", "duplicate body name 'link_1'")
    d = _base()
    _joint(d, "B2")["name"] = "link_2"
    _fails(d, "'link_2' is already a body name")
    d = _base()
    d["derived"]["l1"] = "2 * l2"
    _fails(d, "derived.l1", "duplicate name", "already a parameter")
    d = _base()
    _joint(d, "A2")["variable"] = "theta_1"
    _fails(d, "joint 'A2'.variable", "duplicate name 'theta_1'")
    d = _base()
    d["output"]["coordinates"][2] = "theta_1"
    _fails(d, "output.coordinates", "'theta_1' is also the variable of joint 'A1'")
    # a key given twice in the YAML text (PyYAML alone would keep the last)
    text = (DESC / "p2_three_rrr.yaml").read_text(encoding="utf-8")
    bad = text.replace("  l2: mechanism.l2_m\n", "  l2: mechanism.l2_m\n  l1: mechanism.l2_m\n")
    assert bad != text
    path = tmp_path / "dup.yaml"
    path.write_text(bad, encoding="utf-8")
    _fails(str(path), "dup.yaml", "duplicate key 'l1'")


# --------------------------------------------------------------------------- parameters and units
def test_missing_parameter_key_in_the_params_file():
    d = _base()
    d["parameters"]["l1"] = "mechanism.l9_m"
    _fails(d, "parameters.l1", "'mechanism.l9_m' is absent from data/params/p2.json")


def test_unknown_paper_and_reserved_symbol():
    d = _base()
    d["paper"] = "p9"
    _fails(d, "paper:", "p9", "available names")
    d = _base()
    d["parameters"]["pi"] = "mechanism.l1_m"
    _fails(d, "parameters.pi", "constant")


def test_retyped_parameter_value_is_refused():
    d = _base()
    d["parameters"]["l1"] = 0.18
    _fails(d, "parameters.l1", "dotted key", "never retyped")


def test_undeclared_symbol_in_a_placement():
    d = _base()
    _joint(d, "B1")["at"] = ["l_1", 0]
    _fails(d, "joint 'B1'.at[0]", "unknown symbol 'l_1'", "l1, l2, l3")


def test_missing_units():
    d = _base()
    del d["units"]["length"]
    _fails(d, "units", "missing key(s) ['length']")
    d = _base()
    d["output"]["units"] = ["m", "m"]
    _fails(d, "output.units", "one unit per coordinate")
    d = _base()
    d["output"]["units"] = ["m", "m", "deg"]
    _fails(d, "output.units", "'phi'", "'rad'")
    d = _base()
    d["units"]["length"] = "inch"
    _fails(d, "units.length", "['m', 'mm']")


def test_unknown_top_level_and_joint_keys():
    d = _base()
    d["joint"] = []
    _fails(d, "unknown key(s) ['joint']", "accepted")
    d = _base()
    _joint(d, "A1")["axes"] = [[0, 0, 1], [1, 0, 0]]
    _fails(d, "joint 'A1'.axes", "only a universal joint")


# --------------------------------------------------------------------------- expressions
@pytest.mark.parametrize(
    "expr, fragment",
    [
        ("__import__('os').system('true')", "calling"),
        ("l1.real", "Attribute"),
        ("l1[0]", "Subscript"),
        ("'l1'", "the constant 'l1'"),
        ("exp(l1)", "calling 'exp'"),
        ("sqrt(l1, l2)", "sqrt takes 1 argument(s)"),
        ("l1 +", "cannot parse"),
        ("lambda: 1", "Lambda"),
        ("l1 if l2 else l3", "IfExp"),
        ("l1 // 2", "FloorDiv"),
    ],
)
def test_bad_expressions(expr, fragment):
    d = _base()
    d["derived"]["r_p"] = expr
    _fails(d, "derived.r_p", fragment)


def test_wrong_number_of_placement_values():
    d = _base()
    _joint(d, "B1")["at"] = [0.18, 0, 0]
    _fails(d, "joint 'B1'.at", "expected 2 values, got 3")
    d = _base("p3_mechanism_a")
    _joint(d, "D")["child_at"] = [0, "l3"]
    _fails(d, "joint 'D'.child_at", "expected 3 values, got 2")
    d = _base()
    d["output"]["position"] = ["x_P"]
    _fails(d, "output.position", "expected 2 values, got 1")


def test_an_output_coordinate_unused():
    d = _base()
    d["output"]["rotation"] = 0
    _fails(d, "output.coordinates", "'phi' is used neither")


def test_output_without_rotation_or_point():
    d = _base()
    del d["output"]["rotation"]
    _fails(d, "output", "missing key 'rotation'", "point: true")


def test_a_prismatic_leg_off_the_line_of_centres():
    d = _base("planar_3rpr")
    _joint(d, "P2")["at"] = [0, 0.05]
    _fails(d, "joint 'P2'", "not along the line of the two end centres")


def test_a_parallelogram_twin_that_is_not_parallel():
    d = _base("delta")
    _joint(d, "P2b")["child_at"] = ["r_p", "w", 0]
    _fails(d, "rod_2b", "in no loop, and it is not the parallel twin")


def test_bad_path_or_dict():
    with pytest.raises(ValueError, match="no description file"):
        pk.load_mechanism("data/mechanisms/none.yaml")
    with pytest.raises(ValueError, match="path_or_dict must be"):
        pk.load_mechanism(3)
    d = copy.deepcopy(_base())
    d["space"] = "curved"
    _fails(d, "space", "'planar' or 'spatial'")


# --------------------------------------------------------------------------- nodes (P3 B) and R-P arms (P5)
def _node(d):
    return d["nodes"][0]


def test_nodes_only_in_a_spatial_description():
    d = _base()
    d["nodes"] = [{"name": "N", "joints": ["C1"], "locate": ["a.plane", "b.plane", "c.distance"], "toward": [0, 1]}]
    _fails(d, "nodes", "only a spatial description has nodes")


def test_a_node_located_by_three_distances():
    d = _base("p3_mechanism_b")
    _node(d)["locate"] = ["rod_1.distance", "rod_2.distance", "link_CD.distance"]
    _fails(d, "node 'C'.locate", "two planes and one distance", "0 plane(s) and 3 distance(s)")


def test_a_node_located_by_parallel_planes():
    d = _base("p3_mechanism_b")
    _node(d)["locate"] = ["rod_1.plane", "rod_2.plane", "rod_1.distance"]
    _fails(d, "node 'C'", "are parallel")


def test_a_node_plane_of_a_link_without_a_revolute_end():
    d = _base("p3_mechanism_b")
    _joint(d, "B2")["type"] = "universal"
    del _joint(d, "B2")["axis"]
    _node(d)["locate"] = ["rod_1.plane", "link_CD.plane", "rod_2.distance"]
    d["overconstraints"]["count"] = 2
    _node(d)["locate"][0] = "rod_2.plane"
    _fails(d, "node 'C'", "locate[0] rod_2.plane", "has no plane")


def test_a_node_constraint_in_no_loop_and_a_loop_that_closes_none():
    d = _base("p3_mechanism_b")
    del d["loops"][1]
    _fails(d, "the constraint rod_2.distance of node 'C' is in no loop")
    d = _base("p3_mechanism_b")
    d["loops"][1] = ["P2", "B2", "C12", "B1", "P1"]
    _fails(d, "loops[1]", "closes no constraint", "link 'rod_1'")


def test_an_unknown_node_joint_and_a_bad_toward():
    d = _base("p3_mechanism_b")
    _node(d)["joints"] = ["C12", "C9"]
    _fails(d, "node 'C'.joints", "unknown joint 'C9'")
    d = _base("p3_mechanism_b")
    _node(d)["toward"] = [0, 1]
    _fails(d, "node 'C'.toward", "expected 3 values")


def test_p5_as_prrs_is_refused_and_a_prismatic_along_the_axis_too():
    """P5's P R R S chains bind A_i only by an inequality (the arm's reach) besides the plane: the
    loader refuses the two-link arm and says to describe the chain as P R P S."""
    d = _base("p5_decoupled_6prps")
    t1 = _joint(d, "T1")
    t1["type"] = "revolute"
    t1["axis"] = [1, 0, 0]
    _fails(d, "passive revolute 'T1'", "reach", "inequality", "P R P S")
    d = _base("p5_decoupled_6prps")
    _joint(d, "T1")["axis"] = [1, 0, 0]
    _fails(d, "joint 'T1'", "must slide across the axis of the revolute 'R1'")
