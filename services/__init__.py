"""Thin processes that wire acquisition and reconstruction to the Zenoh bus, and the CLI."""
