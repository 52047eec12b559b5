"""The SVG document under a map: its XML (nesting bounded), its size and origin, its labelled shapes.

What the map importer (``core.maps.svg``) reads before it knows what any shape means: the root's size and
viewBox origin, and every <rect>, <path> and <circle> in document order with its label and the transform
accumulated down to it (identity unless transforms are applied).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from foresight.core.errors import ConfigError
from foresight.core.limits import MAX_NESTING
from foresight.core.maps import svgtransform
from foresight.core.maps.model import Point

SVG_NS = "http://www.w3.org/2000/svg"
INKSCAPE_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
SHAPES = ("rect", "path", "circle")  #: the elements a map is drawn with

_LENGTH = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")


@dataclass(frozen=True)
class Element:
    """One <rect>, <path> or <circle> with its label and accumulated transform."""

    tag: str
    attrib: dict[str, str]
    matrix: svgtransform.Affine

    @property
    def elem_id(self) -> str:
        return self.attrib.get("id", "")

    @property
    def label(self) -> str:
        """inkscape:label, else id (circles: label, else class, else id)."""
        own = self.attrib.get(INKSCAPE_LABEL, "")
        if self.tag == "circle":
            return own or self.attrib.get("class", "") or self.elem_id
        return own or self.elem_id

    def describe(self) -> str:
        own = self.attrib.get(INKSCAPE_LABEL)
        return f"<{self.tag} id={self.elem_id!r}" + (f" label={own!r}>" if own else ">")


def length(text: str | None) -> float | None:
    """A number with an optional unit suffix, which is stripped, not converted (as the reference does)."""
    if text is None:
        return None
    m = _LENGTH.match(text)
    return float(m.group(1)) if m else None


def local_name(tag: str) -> str | None:
    """The element name if it is in the SVG namespace (or has none)."""
    if tag.startswith("{"):
        ns, _, name = tag[1:].partition("}")
        return name if ns == SVG_NS else None
    return tag


def parse_xml(text: str | bytes, source: str) -> ET.Element:
    """The document's root element; nesting deeper than MAX_NESTING elements is refused while parsing
    (the importer walks the tree recursively)."""
    parser = ET.XMLPullParser(events=("start", "end"))
    root, depth, chunk = None, 0, 1 << 16
    try:
        for at in range(0, len(text), chunk):
            parser.feed(text[at : at + chunk])
            for event, elem in parser.read_events():
                root = root if root is not None else elem
                depth += 1 if event == "start" else -1
                if depth > MAX_NESTING:
                    raise ConfigError(
                        f"elements nested deeper than {MAX_NESTING} levels",
                        source=source,
                        item=f"<{elem.tag.rpartition('}')[2]}>",
                    )
        parser.close()
    except ET.ParseError as exc:
        raise ConfigError(f"malformed XML: {exc}", source=source, item="xml") from exc
    if root is None:
        raise ConfigError("malformed XML: no element found", source=source, item="xml")
    return root


def document_size(root: ET.Element, source: str) -> tuple[float, float, Point]:
    """(width, height, viewBox origin) of the <svg> root; width and height fall back to the viewBox's."""
    if local_name(root.tag) != "svg":
        raise ConfigError(f"root element is {root.tag!r}, expected <svg>", source=source, item="svg")
    width, height = length(root.get("width")), length(root.get("height"))
    origin = (0.0, 0.0)
    view_box = root.get("viewBox") or root.get("viewbox")
    if view_box:
        parts = view_box.replace(",", " ").split()
        if len(parts) != 4 or any(length(p) is None for p in parts):
            raise ConfigError(f"viewBox {view_box!r} is not four numbers", source=source, item="svg viewBox")
        vx, vy, vw, vh = (float(length(p)) for p in parts)
        origin = (vx, vy)
        width = width or vw
        height = height or vh
    if not width or not height or width <= 0 or height <= 0:
        raise ConfigError(
            "width/height missing or not positive and not given by the viewBox", source=source, item="svg"
        )
    return float(width), float(height), origin


def collect_shapes(root: ET.Element, source: str, apply_transforms: bool) -> dict[str, list[Element]]:
    """Every shape of the document by tag, in document order, with transforms accumulated when applied."""
    shapes: dict[str, list[Element]] = {tag: [] for tag in SHAPES}

    def walk(elem: ET.Element, matrix: svgtransform.Affine) -> None:
        if apply_transforms:
            try:
                own = svgtransform.parse_transform(elem.get("transform"))
            except svgtransform.TransformError as exc:
                raise ConfigError(
                    str(exc),
                    source=source,
                    item=f"<{local_name(elem.tag)} id={elem.get('id', '')!r}> transform",
                ) from exc
            matrix = svgtransform.compose(matrix, own)
        tag = local_name(elem.tag) if isinstance(elem.tag, str) else None
        if tag in shapes:
            shapes[tag].append(Element(tag, dict(elem.attrib), matrix))
        for child in elem:
            walk(child, matrix)

    walk(root, svgtransform.IDENTITY)
    return shapes
