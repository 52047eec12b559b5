"""Maps: the map model (``model``), the SVG importer (``svg``), our YAML format (``native``),
loading by file (``io.load_map``) and map catalogues (``registry.MapRegistry``)."""
