"""A simulate job names its planner like an evaluation does (a bare name stays accepted); a typo is a 422."""

from __future__ import annotations


def test_simulate_takes_a_planner_spec(client, auth) -> None:  # noqa: ANN001
    base = {"kind": "simulate", "scenarios": ["crossing_low"], "seeds": [1000], "render": False}
    for planner in ("goal", {"name": "orca"}, {"name": "predictive", "model": "cv"}):
        response = client.post("/v1/jobs", json={"spec": {**base, "planner": planner}}, headers=auth)
        assert response.status_code == 201, response.text
        assert response.json()["spec"]["planner"]["name"] == (
            planner if isinstance(planner, str) else planner["name"]
        )
    typo = client.post("/v1/jobs", json={"spec": {**base, "planner": {"name": "orcaa"}}}, headers=auth)
    assert typo.status_code == 422 and "unknown planner 'orcaa'" in typo.text
