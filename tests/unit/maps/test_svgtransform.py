"""SVG transform lists as affine maps."""

from __future__ import annotations

import pytest

from foresight.core.maps.svgtransform import TransformError, apply, compose, parse_transform


@pytest.mark.parametrize(
    ("text", "point", "expected"),
    [
        (None, (1, 2), (1, 2)),
        ("translate(1,2)", (0, 0), (1, 2)),
        ("translate(3)", (1, 1), (4, 1)),
        ("scale(2)", (1, 3), (2, 6)),
        ("scale(2, 3)", (1, 1), (2, 3)),
        ("rotate(90)", (1, 0), (0, 1)),
        ("rotate(90 1 1)", (2, 1), (1, 2)),
        ("matrix(1 0 0 1 5 6)", (1, 1), (6, 7)),
        ("matrix(0,1,-1,0,0,0)", (1, 0), (0, 1)),
        ("skewX(45)", (0, 1), (1, 1)),
        ("skewY(45)", (1, 0), (1, 1)),
        ("translate(10,0) scale(2)", (1, 1), (12, 2)),  # right-most applies first
        ("scale(2),translate(10,0)", (1, 1), (22, 2)),
    ],
)
def test_transform_functions(text, point, expected):
    assert apply(parse_transform(text), point) == pytest.approx(expected)


def test_compose_is_parent_after_child():
    parent, child = parse_transform("translate(5,0)"), parse_transform("rotate(90)")
    assert apply(compose(parent, child), (1, 0)) == pytest.approx((5, 1))


@pytest.mark.parametrize("text", ["translate(1,2,3)", "foo(1)", "translate(1", "rotate(1 2)", "scale(a)"])
def test_bad_transform_raises(text):
    with pytest.raises(TransformError):
        parse_transform(text)
