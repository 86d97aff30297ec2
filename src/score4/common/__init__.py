"""The foundation every package builds on: units and their text (:mod:`.units`), the bounds on
sizes and counts (:mod:`.limits`), the pydantic base and field types of every model
(:mod:`.schema`), and safe YAML reading (:mod:`.yamlfile`). They import nothing of score4 but
``score4.errors`` and each other (no Geant4)."""
