"""Label files: :class:`LabelRecord`, one line of ``labels.jsonl`` per mesh, and :func:`read_labels`.

The procedural dataset (:mod:`rail_mj.dataset.procedural`) and the real-mesh set
(:mod:`rail_mj.dataset.realset`) write these files; ``python -m rail_mj.eval`` reads them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from rail_mj.affordances import label_key as normalize_affordance
from rail_mj.core.errors import DatasetError

__all__ = [
    "LABELS_FILE",
    "Vec3",
    "LabelRecord",
    "read_labels",
]

LABELS_FILE = "labels.jsonl"

Vec3 = tuple[float, float, float]


class LabelRecord(BaseModel):
    """One line of ``labels.jsonl``. ``nominal_up`` is the vector, in the file's own frame (before the
    ``up`` change), that is up in the object's natural (as-built) pose, present for every object;
    ``functional_up`` equals it and is present only when the object affords at least one of the listed
    names. ``corruptions`` lists what was done to the file (omitted when nothing was)."""

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

    mesh: str = Field(min_length=1)
    class_name: str = Field(alias="class", min_length=1)
    affordances: dict[str, bool]
    functional_up: Vec3 | None = None
    #: other ups (file frame) that give the same shape as functional_up: an object that is itself turned upside
    #: down (a pouf without feet, a console on a plinth) is as functional either way up
    equivalent_ups: list[Vec3] | None = None
    nominal_up: Vec3 | None = None
    units: float = Field(default=1.0, gt=0)
    up: Literal["z", "y"] = "z"  # the file's up axis, as rail_mj.mesh.load_mesh takes it
    #: the file stands the object as it came to rest (a real mesh as made, rail_mj.pipeline.config.ObjectInput);
    #: False: written in an arbitrary orientation (the procedural set's random rotations)
    oriented: bool = True
    # what was done to the file (rail_mj.dataset.ground_truth.CORRUPTIONS); None: nothing
    corruptions: list[str] | None = None
    notes: str = ""

    @field_validator("affordances")
    @classmethod
    def _canonical_names(cls, v: dict[str, bool]) -> dict[str, bool]:
        out: dict[str, bool] = {}
        given: dict[str, str] = {}
        for name, label in v.items():
            key = normalize_affordance(name)
            if key in out:  # one would silently overwrite the other
                raise ValueError(f"{given[key]!r} and {name!r} both name the affordance {key!r}; label it once")
            out[key], given[key] = label, name
        return out

    @field_validator("functional_up", "nominal_up")
    @classmethod
    def _unit(cls, v: Vec3 | None) -> Vec3 | None:
        if v is None:
            return v
        n = float(np.linalg.norm(v))
        if abs(n - 1.0) > 1e-3:
            raise ValueError(f"must be a unit vector, got {list(v)} of length {n:.4f}")
        if abs(n - 1.0) < 1e-6:  # keep already-unit values as written so files round-trip byte for byte
            return tuple(float(x) for x in v)  # type: ignore[return-value]
        return tuple(float(x) / n for x in v)  # type: ignore[return-value]

    @model_validator(mode="after")
    def _up_iff_functional(self) -> "LabelRecord":
        if any(self.affordances.values()) and self.functional_up is None:
            raise ValueError("functional_up is required when any affordance is true")
        if not any(self.affordances.values()) and self.functional_up is not None:
            raise ValueError("functional_up must be omitted when no affordance is true")
        if self.equivalent_ups is not None and self.functional_up is None:
            raise ValueError("equivalent_ups needs a functional_up")
        for v in self.equivalent_ups or []:
            if abs(float(np.linalg.norm(v)) - 1.0) > 1e-3:
                raise ValueError(f"equivalent_ups must be unit vectors, got {list(v)}")
        return self

    def mesh_path(self, root: str | Path) -> Path:
        """The mesh file, resolved against the dataset folder."""
        return Path(root) / self.mesh

    def to_json(self) -> str:
        return json.dumps(self.model_dump(mode="json", by_alias=True, exclude_none=True), ensure_ascii=False)


def read_labels(path: str | Path) -> list[LabelRecord]:
    """Read ``labels.jsonl`` from a dataset folder (or the file itself); every mesh must exist."""
    p = Path(path)
    file = p / LABELS_FILE if p.is_dir() else p
    if not file.is_file():
        raise DatasetError(f"no labels file at {file}; expected a folder holding {LABELS_FILE} or the file itself")
    root = file.parent
    records = []
    for lineno, line in enumerate(file.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            data = json.loads(line)
        except json.JSONDecodeError as e:
            raise DatasetError(f"{file}:{lineno}: not valid JSON ({e.msg} at column {e.colno})") from e
        try:
            record = LabelRecord.model_validate(data)
        except ValidationError as e:
            errs = "; ".join(f"{'.'.join(map(str, err['loc'])) or 'record'}: {err['msg']}" for err in e.errors())
            fields = ", ".join(f.alias or n for n, f in LabelRecord.model_fields.items())
            raise DatasetError(f"{file}:{lineno}: bad label ({errs}); fields: {fields}") from e
        if not record.mesh_path(root).is_file():
            raise DatasetError(f"{file}:{lineno}: mesh file {record.mesh_path(root)} does not exist")
        records.append(record)
    if not records:
        raise DatasetError(f"{file} holds no label records")
    return records
