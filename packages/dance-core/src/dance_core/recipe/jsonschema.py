"""JSON Schema of recipes, with each component's options spelled out from the installed plugins."""

from __future__ import annotations

from typing import Any

from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry

#: where components of each kind sit in the recipe schema (JSON pointer-ish paths to ComponentSpec)
SLOTS: dict[str, list[tuple[str, ...]]] = {
    "feature": [("properties", "features", "additionalProperties", "items")],
    "conditioner": [("$defs", "ModelSpec", "properties", "conditioners", "additionalProperties")],
    "encoder": [("$defs", "ModelSpec", "properties", "encoder")],
    "head": [("$defs", "ModelSpec", "properties", "head")],
    "dataset": [("$defs", "DataSpec", "properties", "dataset")],
    "motion-representation": [("properties", "motion")],
    "schedule": [
        ("$defs", "TrainingSpec", "properties", "lr_schedule"),
        ("$defs", "TrainingSpec", "properties", "schedules", "additionalProperties"),
    ],
}


def _component_schema(kind: str, registry: Registry, defs: dict[str, Any]) -> dict[str, Any]:
    options = []
    for entry in registry.entries(kind):
        schema = entry.config.model_json_schema() if entry.config else {"type": "object", "properties": {}}
        defs.update(schema.pop("$defs", {}))
        schema["properties"] = {"plugin": {"const": entry.name}, **schema.get("properties", {})}
        schema["required"] = ["plugin", *schema.get("required", [])]
        schema["additionalProperties"] = False
        schema["description"] = f"{entry.description} ({entry.distribution} {entry.version})"
        options.append(schema)
    return {"oneOf": options} if options else {"type": "object"}


def recipe_json_schema(registry: Registry) -> dict[str, Any]:
    """The recipe schema for editors (``# yaml-language-server: $schema=...``)."""
    schema = Recipe.model_json_schema()
    defs = schema.setdefault("$defs", {})
    for kind, slots in SLOTS.items():
        defs[f"{kind}-component"] = _component_schema(kind, registry, defs)
        for slot in slots:
            node = schema
            for key in slot[:-1]:
                node = node[key]
            ref = {"$ref": f"#/$defs/{kind}-component"}
            current = node[slot[-1]]
            if "$ref" in current or "items" not in current:
                node[slot[-1]] = {**{k: v for k, v in current.items() if k in ("default", "description")}, **ref}
    return schema
