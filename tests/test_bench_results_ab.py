"""The comparison of benchmarks/bench_results_ab.py finds every kind of difference."""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(__file__)), "benchmarks"))

import bench_results_ab as ab


def test_equal_documents_have_no_differences():
    doc = {"a": [1.0, 2.5, float("nan")], "b": {"c": 3, "d": "x"}}
    assert ab.compare(doc, {"a": [1.0, 2.5, float("nan")], "b": {"c": 3, "d": "x"}}) == []


def test_one_ulp_is_found_and_counted():
    x = 0.1
    y = math.nextafter(x, 1.0)
    (diff,) = ab.compare({"v": [x]}, {"v": [y]})
    assert diff[0] == "/v[0]" and diff[3] == 1.0


def test_structure_and_text_differences_are_found():
    diffs = ab.compare({"a": 1, "b": [1, 2], "s": "x"}, {"b": [1], "s": "y", "c": 2})
    paths = {d[0] for d in diffs}
    assert paths == {"/a", "/b", "/c", "/s"}
    assert all(d[3] == math.inf for d in diffs)


def test_volatile_keys_are_skipped():
    a = {"elapsed_seconds": 1.0, "wall_time": {"x": 1}, "f": 2.0}
    b = {"elapsed_seconds": 9.0, "wall_time": {"x": 5}, "f": 2.0}
    assert ab.compare(a, b, skip=ab.VOLATILE) == []
    assert len(ab.compare(a, b)) == 2
