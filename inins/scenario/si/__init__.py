"""Scenario models into the methods' SI objects.

The one place where ``scenario/`` meets the method packages: each module takes a
validated scenario model (lab units, as the YAML states them) and builds the SI
objects of one method package. The models themselves import no method package;
``commands/`` calls these converters.
"""
