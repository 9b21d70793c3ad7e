"""Scenarios: YAML files validated into typed objects, runs, batches, metrics."""
