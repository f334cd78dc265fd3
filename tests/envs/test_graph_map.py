"""Graph maps of places and ways (paper 003, section 2): model, validation, files, paths, drawing."""

import copy
import json
import math
import re

import networkx as nx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from teamgym.maps import (
    GraphMap,
    MapError,
    NoPathError,
    Place,
    Way,
    available_graph_maps,
    graph_map_from_dict,
    load_graph_map,
    plot_graph_map,
    save_graph_map,
    validate_graph_map,
)
from teamgym.maps.graph import SIZE_MARGIN

SRC = "src.json"


def square(**changes):
    """A valid map dict: the corners of a 2 m square, one diagonal and a bent way B-C."""
    data = {
        "name": "sq",
        "size": [3.0, 3.0],
        "places": [
            {"id": "A", "x": 0.5, "y": 0.5},
            {"id": "B", "x": 2.5, "y": 0.5},
            {"id": "C", "x": 2.5, "y": 2.5},
            {"id": "D", "x": 0.5, "y": 2.5},
        ],
        "ways": [
            {"a": "A", "b": "B"},
            {"a": "B", "b": "C", "length": 2.2, "width": 0.4},
            {"a": "C", "b": "D"},
            {"a": "D", "b": "A"},
            {"a": "A", "b": "C"},
        ],
    }
    data.update(changes)
    return data


def ladder():
    """A hand-made map with a known shortest path: two rails 0-1-2-3 (bottom) and 4-5-6-7 (top), joined by rungs."""
    places = [Place(str(i), float(i % 4), 0.0 if i < 4 else 1.0) for i in range(8)]
    ways = [Way("0", "1"), Way("1", "2", 4.0), Way("2", "3"), Way("4", "5"), Way("5", "6"), Way("6", "7", 1.5)]
    ways += [Way("0", "4"), Way("1", "5"), Way("2", "6", 1.2), Way("3", "7")]
    return validate_graph_map(GraphMap("ladder", tuple(places), tuple(ways)))


def brute_force(graph_map, a, b, blocked=()):
    """Minimal length over every simple path from a to b (depth-first enumeration), or None."""
    cut = {frozenset(w) for w in blocked}
    adjacent = {p.id: [] for p in graph_map.places}
    for w in graph_map.ways:
        if frozenset((w.a, w.b)) not in cut:
            adjacent[w.a].append((w.b, w.length))
            adjacent[w.b].append((w.a, w.length))
    best = None

    def walk(node, seen, total):
        nonlocal best
        if node == b:
            best = total if best is None else min(best, total)
            return
        for nxt, length in adjacent[node]:
            if nxt not in seen:
                walk(nxt, seen | {nxt}, total + length)

    walk(a, {a}, 0.0)
    return best


def path_length(graph_map, path):
    return sum(graph_map.way(u, v).length for u, v in zip(path, path[1:]))


@st.composite
def graph_maps(draw, max_places=7):
    """Valid, connected graph maps with random ids, coordinates, lengths, widths and size."""
    n = draw(st.integers(1, max_places))
    ids = draw(st.lists(st.text(min_size=1, max_size=4), min_size=n, max_size=n, unique=True))
    coord = st.floats(0.0, 5.0, allow_nan=False)
    points = draw(st.lists(st.tuples(coord, coord), min_size=n, max_size=n, unique=True))
    places = [Place(i, x, y) for i, (x, y) in zip(ids, points)]
    pairs = [(draw(st.integers(0, k - 1)), k) for k in range(1, n)]  # a spanning tree
    extra = draw(st.sets(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=n))
    for i, j in sorted(extra):
        if i != j and (i, j) not in pairs and (j, i) not in pairs:
            pairs.append((i, j))
    ways = []
    for i, j in pairs:
        if draw(st.booleans()):
            i, j = j, i
        factor = draw(st.one_of(st.none(), st.floats(1.0, 3.0)))
        length = None if factor is None else math.dist(points[i], points[j]) * factor
        width = draw(st.one_of(st.none(), st.floats(0.01, 1.0)))
        ways.append(Way(ids[i], ids[j], length, width))
    size = None
    if draw(st.booleans()):
        size = tuple(max(v) + draw(st.floats(0.01, 2.0)) for v in zip(*points))
    return validate_graph_map(
        GraphMap(
            name=draw(st.text(min_size=1, max_size=8)),
            places=tuple(places),
            ways=tuple(ways),
            size=size,
            allow_disconnected=draw(st.booleans()),
            description=draw(st.text(max_size=10)),
        )
    )


# -- the model --------------------------------------------------------------------------


def test_shipped_square4_loads_and_answers_queries():
    assert "square4" in available_graph_maps()
    m = load_graph_map("square4")
    assert m.name == "square4" and m.source == "square4.json"
    assert m.place_ids == ["A", "B", "C", "D"]
    assert m.place("C").pos == (2.5, 2.5)
    assert sorted(m.neighbours("A")) == ["B", "C", "D"]
    assert m.way("C", "A") is m.way("A", "C")
    assert m.way("A", "C").length == pytest.approx(2 * math.sqrt(2))
    assert m.shortest_path("A", "C", blocked=[("A", "C")]) == ["A", "D", "C"]


def test_lookups_name_what_is_missing():
    m = load_graph_map("square4")
    with pytest.raises(KeyError, match="no place 'Z'"):
        m.place("Z")
    with pytest.raises(KeyError, match="no place 'Z'"):
        m.neighbours("Z")
    with pytest.raises(KeyError, match="no way between 'B' and 'D'"):
        m.way("B", "D")


def test_length_defaults_to_the_straight_line_and_size_to_the_bounding_box():
    m = graph_map_from_dict(
        {"places": [{"id": "p", "x": 0.0, "y": 1.0}, {"id": "q", "x": 3.0, "y": 5.0}], "ways": [{"a": "p", "b": "q"}]}
    )
    assert m.way("p", "q").length == 5.0
    assert m.way("p", "q").width is None
    assert m.size == (3.0 + SIZE_MARGIN, 5.0 + SIZE_MARGIN)
    assert graph_map_from_dict(square()).way("B", "C").length == 2.2


def test_to_networkx_carries_positions_lengths_weights_and_widths():
    m = graph_map_from_dict(square())
    g = m.to_networkx()
    assert isinstance(g, nx.Graph) and not g.is_directed()
    assert g.number_of_nodes() == 4 and g.number_of_edges() == 5
    assert g.nodes["B"]["pos"] == (2.5, 0.5)
    assert g.edges["C", "B"] == {"length": 2.2, "weight": 2.2, "width": 0.4}
    assert g.edges["A", "B"]["length"] == g.edges["A", "B"]["weight"] == 2.0
    assert g.edges["A", "B"]["width"] is None
    g.remove_edge("A", "C")  # a new graph each call: the map is unchanged
    assert m.to_networkx().has_edge("A", "C") and m.shortest_path("A", "C") == ["A", "C"]


def test_graph_map_is_frozen():
    m = load_graph_map("square4")
    with pytest.raises(AttributeError):
        m.name = "other"
    assert hash(m) == hash(load_graph_map("square4"))


# -- shortest paths ---------------------------------------------------------------------


def test_shortest_path_matches_the_known_answer_and_brute_force():
    m = ladder()
    # bottom 0-1-2-3 costs 1 + 4 + 1; the top rail 4-5-6-7 costs 1 + 1 + 1.5; rungs are 1 (2-6: 1.2)
    assert m.shortest_path("0", "3") == ["0", "1", "5", "6", "2", "3"]
    assert m.shortest_path_length("0", "3") == pytest.approx(1 + 1 + 1 + 1.2 + 1)
    for a in m.place_ids:
        for b in m.place_ids:
            assert m.shortest_path_length(a, b) == pytest.approx(brute_force(m, a, b))
            assert path_length(m, m.shortest_path(a, b)) == pytest.approx(m.shortest_path_length(a, b))


def test_blocking_a_way_reroutes_in_either_direction_and_accepts_way_objects():
    m = ladder()
    blocked = [("6", "5")]
    assert m.shortest_path("0", "3", blocked=blocked) == ["0", "1", "2", "3"]
    assert m.shortest_path_length("0", "3", blocked=blocked) == pytest.approx(6.0)
    assert m.shortest_path("0", "3", blocked=[m.way("2", "6"), ("1", "5")]) == ["0", "4", "5", "6", "7", "3"]
    assert m.shortest_path_length("0", "3", blocked=[("2", "6"), ("5", "1")]) == pytest.approx(5.5)
    assert m.shortest_path("0", "3") == ["0", "1", "5", "6", "2", "3"]  # blocking did not change the map
    assert m.shortest_path("2", "2") == ["2"] and m.shortest_path_length("2", "2") == 0.0


def test_blocked_items_must_be_ways():
    m = ladder()
    with pytest.raises(KeyError, match="no way between '0' and '3'"):
        m.shortest_path("0", "3", blocked=[("0", "3")])
    with pytest.raises(TypeError, match="pair of place ids"):
        m.shortest_path("0", "3", blocked=["06"])
    with pytest.raises(KeyError, match="no place 'x'"):
        m.shortest_path("0", "x")


def test_unreachable_raises_a_clear_error_naming_the_places():
    m = ladder()
    cut = [("0", "1"), ("0", "4")]
    with pytest.raises(NoPathError, match=r"no path from '0' to '7' with way\(s\) \[\['0', '1'\], \['0', '4'\]\] blocked"):
        m.shortest_path("0", "7", blocked=cut)
    with pytest.raises(NoPathError, match="no path from '7' to '0'"):
        m.shortest_path_length("7", "0", blocked=cut)
    islands = graph_map_from_dict(
        {"allow_disconnected": True, "places": [{"id": "p", "x": 0, "y": 0}, {"id": "q", "x": 1, "y": 0}]}
    )
    with pytest.raises(NoPathError, match="graph map '<graph map>': no path from 'p' to 'q'$") as caught:
        islands.shortest_path("p", "q")
    assert isinstance(caught.value, nx.NetworkXNoPath) and isinstance(caught.value, ValueError)


@settings(max_examples=80, deadline=None)
@given(data=st.data())
def test_shortest_paths_equal_brute_force_on_random_maps(data):
    m = data.draw(graph_maps(max_places=6))
    a, b = data.draw(st.sampled_from(m.place_ids)), data.draw(st.sampled_from(m.place_ids))
    blocked = data.draw(st.lists(st.sampled_from(m.ways), unique=True)) if m.ways else []
    pairs = [(w.b, w.a) for w in blocked]  # the reverse direction blocks the same way
    best = brute_force(m, a, b, pairs)
    if best is None:
        with pytest.raises(NoPathError, match=re.escape(f"from {a!r} to {b!r}")):
            m.shortest_path(a, b, blocked=pairs)
    else:
        path = m.shortest_path(a, b, blocked=pairs)
        assert path[0] == a and path[-1] == b
        assert not {frozenset(p) for p in zip(path, path[1:])} & {frozenset(p) for p in pairs}
        assert path_length(m, path) == pytest.approx(best)
        assert m.shortest_path_length(a, b, blocked=pairs) == pytest.approx(best)


# -- round trips ------------------------------------------------------------------------


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(m=graph_maps())
def test_json_round_trip_gives_an_equal_map(m, tmp_path):
    path = save_graph_map(m, tmp_path / "sub" / "m.json")
    loaded = load_graph_map(path)
    assert loaded == m
    assert loaded.source == str(path)
    assert json.loads(path.read_text()) == m.to_dict()


@settings(max_examples=100, deadline=None)
@given(m=graph_maps())
def test_dict_round_trip_gives_an_equal_map(m):
    data = m.to_dict()
    assert graph_map_from_dict(json.loads(json.dumps(data))) == m
    assert graph_map_from_dict(data).to_dict() == data


def test_to_dict_leaves_out_defaults():
    data = load_graph_map("square4").to_dict()
    assert "size" not in data and "allow_disconnected" not in data  # (3, 3) is the derived size
    assert data["ways"][0] == {"a": "A", "b": "B", "width": 0.4}
    assert data["ways"][1] == {"a": "B", "b": "C", "length": 2.2, "width": 0.4}
    wide = graph_map_from_dict(square(size=[4.0, 3.0], allow_disconnected=True)).to_dict()
    assert wide["size"] == [4.0, 3.0] and wide["allow_disconnected"] is True


def test_save_refuses_an_invalid_map(tmp_path):
    bad = GraphMap("bad", (Place("a", 0.0, 0.0), Place("b", 1.0, 0.0)), (Way("a", "b", 0.5),))
    with pytest.raises(MapError, match=r"way \['a', 'b'\]: length 0.5 m is shorter"):
        save_graph_map(bad, tmp_path / "bad.json")
    assert not (tmp_path / "bad.json").exists()


# -- validation -------------------------------------------------------------------------


def _set(path, value):
    def change(d):
        *parents, last = path
        target = d
        for key in parents:
            target = target[key]
        target[last] = value

    return change


def _delete(path):
    def change(d):
        *parents, last = path
        target = d
        for key in parents:
            target = target[key]
        del target[last]

    return change


def _append(key, item):
    return lambda d: d[key].append(item)


BAD = {
    "empty object": (lambda d: d.clear(), "top level: missing key(s) ['places']"),
    "unknown top-level key": (_set(["units"], "mm"), "top level: unknown key(s) ['units']"),
    "name empty": (_set(["name"], ""), "name: expected a non-empty string"),
    "description not text": (_set(["description"], 5), "description: expected a string"),
    "allow_disconnected not a bool": (_set(["allow_disconnected"], "yes"), "allow_disconnected: expected true or false"),
    "size zero": (_set(["size"], [0, 3]), "size: expected [width, height] with finite values > 0"),
    "size one number": (_set(["size"], [3]), "size: expected [width, height]"),
    "size not finite": (_set(["size"], [3, math.inf]), "size: expected a finite number"),
    "places not a list": (_set(["places"], {}), "places: expected a list"),
    "no places": (_set(["places"], []), "a graph map needs at least one place"),
    "place not an object": (_set(["places", 0], "A"), "places[0]: expected an object"),
    "unknown place key": (_set(["places", 0, "z"], 1), "places[0]: unknown key(s) ['z']"),
    "missing place key": (_delete(["places", 0, "y"]), "places[0]: missing key(s) ['y']"),
    "empty place id": (_set(["places", 0, "id"], ""), "places[0].id: expected a non-empty string"),
    "number as place id": (_set(["places", 0, "id"], 7), "places[0].id: expected a non-empty string, got 7"),
    "duplicate place id": (_append("places", {"id": "A", "x": 1, "y": 1}), "duplicate place id(s) ['A']"),
    "x not a number": (_set(["places", 1, "x"], "2.5"), "place 'B'.x: expected a finite number"),
    "x a bool": (_set(["places", 1, "x"], True), "place 'B'.x: expected a finite number, got True"),
    "y nan": (_set(["places", 1, "y"], math.nan), "place 'B'.y: expected a finite number, got nan"),
    "y infinite": (_set(["places", 1, "y"], -math.inf), "place 'B'.y: expected a finite number"),
    "y a huge integer": (_set(["places", 1, "y"], 10**400), "place 'B'.y: expected a finite number"),
    "place outside the size": (_set(["size"], [2.0, 3.0]), "place 'B' at (2.5, 0.5) m lies outside the 2 x 3 m workspace"),
    "negative coordinate": (_set(["places", 0, "x"], -0.1), "place 'A' at (-0.1, 0.5) m lies outside"),
    "ways not a list": (_set(["ways"], "AB"), "ways: expected a list"),
    "way not an object": (_set(["ways", 0], ["A", "B"]), "ways[0]: expected an object"),
    "unknown way key": (_set(["ways", 0, "cost"], 1), "ways[0]: unknown key(s) ['cost']"),
    "missing way end": (_delete(["ways", 0, "b"]), "ways[0]: missing key(s) ['b']"),
    "way end not text": (_set(["ways", 0, "b"], 2), "ways[0].b: expected a non-empty string, got 2"),
    "way to an unknown place": (_set(["ways", 0, "b"], "Z"), "way ['A', 'Z']: unknown place 'Z'"),
    "self-loop": (_set(["ways", 0, "b"], "A"), "way ['A', 'A'] joins place 'A' to itself"),
    "duplicate way": (_append("ways", {"a": "A", "b": "B", "length": 3}), "way ['A', 'B'] is repeated"),
    "duplicate reversed way": (_append("ways", {"a": "B", "b": "A"}), "way ['B', 'A'] is repeated"),
    "length not a number": (_set(["ways", 0, "length"], "2"), "way ['A', 'B'].length: expected a finite number"),
    "length nan": (_set(["ways", 0, "length"], math.nan), "way ['A', 'B'].length: expected a finite number"),
    "length zero": (_set(["ways", 0, "length"], 0), "way ['A', 'B']: length must be a finite number > 0, got 0.0"),
    "length negative": (_set(["ways", 0, "length"], -2), "way ['A', 'B']: length must be a finite number > 0"),
    "length below the straight line": (
        _set(["ways", 4, "length"], 2.8),
        "way ['A', 'C']: length 2.8 m is shorter than the straight line (2.82842712 m) between its places",
    ),
    "width zero": (_set(["ways", 0, "width"], 0), "way ['A', 'B']: width must be a finite number > 0, got 0.0"),
    "width negative": (_set(["ways", 1, "width"], -0.4), "way ['B', 'C']: width must be a finite number > 0"),
    "width null": (_set(["ways", 1, "width"], None), "way ['B', 'C'].width: expected a finite number, got None"),
    "disconnected": (
        _append("places", {"id": "E", "x": 1.5, "y": 1.5}),
        "the graph is disconnected: place(s) ['E'] cannot be reached from 'A' (set \"allow_disconnected\": true",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_every_validation_error_names_the_source_and_the_item(case):
    change, message = BAD[case]
    data = copy.deepcopy(square())
    change(data)
    with pytest.raises(MapError) as caught:
        graph_map_from_dict(data, source=SRC)
    assert str(caught.value).startswith(f"{SRC}: ")
    assert message in str(caught.value)


def test_top_level_must_be_an_object():
    with pytest.raises(MapError, match=r"^src.json: top level: expected an object, got list"):
        graph_map_from_dict([square()], source=SRC)


def test_allow_disconnected_lets_islands_through():
    data = square(allow_disconnected=True)
    data["places"].append({"id": "E", "x": 1.5, "y": 1.5})
    m = graph_map_from_dict(data)
    assert m.allow_disconnected and m.neighbours("E") == []


def test_length_tolerance_is_1e_9():
    straight = 2 * math.sqrt(2)
    ok = graph_map_from_dict(square(ways=square()["ways"][:4] + [{"a": "A", "b": "C", "length": straight - 1e-12}]))
    assert ok.way("A", "C").length == straight - 1e-12
    with pytest.raises(MapError, match=r"way \['A', 'C'\]: length .* is shorter"):
        graph_map_from_dict(square(ways=square()["ways"][:4] + [{"a": "A", "b": "C", "length": straight - 1e-8}]))


@pytest.mark.parametrize(
    ("graph_map", "message"),
    [
        (GraphMap("", (Place("a", 0.0, 0.0),), ()), "name: expected a non-empty string"),
        (GraphMap("g", (Place("a", True, 0.0),), ()), "place 'a': x=True is not a finite number"),
        (GraphMap("g", (Place(None, 0.0, 0.0),), ()), "places[0].id: expected a non-empty string, got None"),
        (GraphMap("g", (Place("a", 0.0, 0.0),), (Way("a", "b"),)), "way ['a', 'b']: unknown place 'b'"),
        (
            GraphMap("g", (Place("a", 0.0, 0.0), Place("b", 1.0, 0.0)), (Way("a", "b", width=math.nan),)),
            "way ['a', 'b']: width must be a finite number > 0, got nan",
        ),
        (GraphMap("g", (Place("a", 1.0, 1.0),), (), size=(1.0, -1.0)), "size: expected [width, height]"),
    ],
)
def test_validate_checks_maps_built_in_code(graph_map, message):
    with pytest.raises(MapError) as caught:
        validate_graph_map(graph_map)
    assert str(caught.value).startswith("<graph map>: ") and message in str(caught.value)


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=4),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3),
    max_leaves=6,
)


@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_bad_input_gives_a_map_error_or_a_valid_map(data):
    d = square()
    where = data.draw(st.sampled_from(["top", "place", "way"]))
    target = {"top": d, "place": d["places"][data.draw(st.integers(0, 3))], "way": d["ways"][data.draw(st.integers(0, 4))]}
    target = target[where]
    key = data.draw(st.sampled_from([*target, "extra"]))
    if data.draw(st.booleans()):
        target[key] = data.draw(JSON)
    else:
        target.pop(key, None)
    try:
        m = graph_map_from_dict(d, source=SRC)
    except MapError as error:
        assert str(error).startswith(f"{SRC}: ")
    else:
        assert validate_graph_map(m) is m


# -- files ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe", "not a JSON graph map file (not UTF-8 text)"),
        (b"\x00\x01\x02 binary", "not valid JSON"),
        (b'{"places": [', "not valid JSON"),
        (b"[" * 100_000, "not valid JSON"),
        (b'{"places": [{"id": "a", "x": ' + b"9" * 5000 + b', "y": 0}]}', "not valid JSON"),
    ],
)
def test_unreadable_files_give_a_map_error_naming_the_file(tmp_path, content, message):
    path = tmp_path / "broken.json"
    path.write_bytes(content)
    with pytest.raises(MapError) as caught:
        load_graph_map(path)
    assert str(path) in str(caught.value) and message in str(caught.value)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(content=st.binary(max_size=64))
def test_random_bytes_give_a_map_error_naming_the_file(content, tmp_path):
    path = tmp_path / "random.bin"
    path.write_bytes(content)
    with pytest.raises(MapError, match="random.bin"):
        load_graph_map(path)


def test_missing_map_lists_the_shipped_ones(tmp_path):
    with pytest.raises(MapError, match=r"no graph map 'nowhere': not a shipped graph map \(\[.*'square4'"):
        load_graph_map("nowhere")
    with pytest.raises(MapError, match="not a shipped graph map"):
        load_graph_map(tmp_path)  # a folder is no file


def test_loaded_file_errors_name_the_path(tmp_path):
    path = tmp_path / "g.json"
    path.write_text(json.dumps(square(ways=[])))
    with pytest.raises(MapError, match=f"^{path}: the graph is disconnected"):
        load_graph_map(path)
    path.write_text("\ufeff" + json.dumps(square()))  # a UTF-8 byte-order mark is accepted
    assert load_graph_map(path) == graph_map_from_dict(square())


# -- drawing ----------------------------------------------------------------------------


def test_plot_draws_one_line_per_way_plus_the_path():
    from matplotlib.colors import to_hex
    from matplotlib.figure import Figure

    m = load_graph_map("square4")
    ax = Figure().subplots()
    assert plot_graph_map(m, ax=ax, blocked=[("C", "A")], path=["A", "D", "C"]) is ax
    assert len(ax.lines) == len(m.ways) + 1
    diagonal = ax.lines[4]
    assert diagonal.get_linestyle() == "--" and to_hex(diagonal.get_color()) == "#c62828"
    assert {line.get_linestyle() for line in ax.lines[:4]} == {"-"}
    assert list(ax.lines[-1].get_xdata()) == [0.5, 0.5, 2.5] and list(ax.lines[-1].get_ydata()) == [0.5, 2.5, 2.5]
    assert sorted(t.get_text() for t in ax.texts) == ["A", "B", "C", "D"]
    assert ax.get_xlim() == (0.0, 3.0)


def test_plot_creates_its_axes_headless():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = plot_graph_map(load_graph_map("square4"), labels=False)
    try:
        assert len(ax.lines) == 5 and not ax.texts
        ax.figure.canvas.draw()
    finally:
        plt.close(ax.figure)


def test_plot_rejects_a_path_that_leaves_the_ways():
    from matplotlib.figure import Figure

    with pytest.raises(KeyError, match="no way between 'B' and 'D'"):
        plot_graph_map(load_graph_map("square4"), ax=Figure().subplots(), path=["A", "B", "D"])
