"""Recipes: YAML files that name every component, validated with pydantic."""

from dance_core.recipe.load import load_recipe, recipe_from_dict
from dance_core.recipe.schema import ComponentSpec, Recipe

__all__ = ["ComponentSpec", "Recipe", "load_recipe", "recipe_from_dict"]
