"""`spacephys bench queries` (a quick run): every query beside cKDTree gives the same answers;
the figures themselves are the benchmark's (docs/performance.md)."""
from spacephys.study import querybench


def test_the_queries_match_ckdtree_and_are_timed():
    results = querybench.queries(quick=True)
    cases = results["cases"]
    assert len(cases) == 14
    assert [c["case"] for c in cases[-2:]] == ["20 x 10 radius queries, 2D",
                                               "20 x 10 radius queries, 3D"]
    for c in cases:
        assert c["spacephys_s"] > 0
        if c["scipy_s"] is not None:
            assert c["same_answers"] is True and c["ratio"] > 0
        if "mean_found" in c and "rays" not in c["case"]:
            assert 5 < c["mean_found"] < 20          # r chosen for about 10 bodies
    table = querybench.format_queries(results)
    assert "cKDTree" in table and table.count("True") == 8
