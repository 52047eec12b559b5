"""Seed manifests: which seeds of which scenarios to run (e.g. a hard-seed campaign).

The file format is the reference's (``predictive_hard_seeds_v1.yaml``): a mapping
``scenario name -> [seed, ...]``. A wrapped form ``{seeds: {name: [...]}, description: ...}`` is
accepted too, so a manifest can carry a description. The same model validates inline manifests
(API bodies), and :meth:`SeedManifest.validate_against` checks the names against a matrix.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError, model_validator

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import read_yaml, validation_message
from foresight.core.scenarios.model import ScenarioMatrix

Seed = Annotated[int, Field(strict=True, ge=0)]


def _unique(seeds: tuple[int, ...]) -> tuple[int, ...]:
    dup = sorted({s for s in seeds if seeds.count(s) > 1})
    if dup:
        raise ValueError(f"seeds listed twice: {dup}")
    return seeds


SeedList = Annotated[tuple[Seed, ...], Field(min_length=1), AfterValidator(_unique)]


class SeedManifest(BaseModel):
    """Scenario name -> ordered seed list; iteration order is file order."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    seeds: dict[str, SeedList]
    description: str | None = None
    source: str | None = None  #: file it was read from (for error messages and provenance)

    @model_validator(mode="before")
    @classmethod
    def _plain_mapping(cls, data: Any) -> Any:
        if isinstance(data, dict) and not isinstance(data.get("seeds"), dict):
            return {"seeds": data}
        return data

    @classmethod
    def from_data(
        cls, data: Any, *, source: str | Path | None = None, matrix: ScenarioMatrix | None = None
    ) -> SeedManifest:
        """Validate parsed data (file content or an inline dict); errors name the source and the scenario."""
        if not isinstance(data, dict) or not data:
            raise ConfigError(
                "a seed manifest must be a non-empty mapping of scenario name -> seeds", source=source
            )
        try:
            manifest = cls.model_validate(data)
        except ValidationError as err:
            loc = err.errors()[0]["loc"]
            item = str(loc[1]) if len(loc) > 1 and loc[0] == "seeds" else ".".join(map(str, loc)) or None
            raise ConfigError(validation_message(err), source=source, item=item) from err
        if source is not None:
            manifest = manifest.model_copy(update={"source": str(source)})
        return manifest.validate_against(matrix) if matrix is not None else manifest

    def validate_against(self, matrix: ScenarioMatrix) -> SeedManifest:
        """Check every scenario exists in ``matrix`` (case-insensitive); names take the matrix's spelling."""
        known = {n.casefold(): n for n in matrix.names}
        renamed: dict[str, tuple[int, ...]] = {}
        for name, seeds in self.seeds.items():
            if name.casefold() not in known:
                raise ConfigError(
                    f"unknown scenario for matrix {matrix.source} (have: {', '.join(matrix.names)})",
                    source=self.source,
                    item=name,
                )
            renamed[known[name.casefold()]] = seeds
        return self.model_copy(update={"seeds": renamed})

    def pairs(self) -> Iterator[tuple[str, int]]:
        """(scenario name, seed) for every episode, in manifest order."""
        for name, seeds in self.seeds.items():
            for seed in seeds:
                yield name, seed

    @property
    def scenario_names(self) -> list[str]:
        return list(self.seeds)

    def __len__(self) -> int:
        """Number of episodes."""
        return sum(len(s) for s in self.seeds.values())


def load_seed_manifest(path: str | Path, matrix: ScenarioMatrix | None = None) -> SeedManifest:
    """Read a seed manifest file, validated against ``matrix`` when given."""
    p = Path(path)
    return SeedManifest.from_data(read_yaml(p), source=p, matrix=matrix)
