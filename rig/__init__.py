"""Composition: configuration, host loop, safety, recorder, identification and the CLI."""

__all__: list[str] = []
