"""Scene generators: plug-ins of the toolkit, one module per generator family.

Each module registers its generators with `vpro_assets.scene.plugins.register`; the toolkit loads
the modules by name (`vpro_assets.scene.plugins.FAMILY_MODULES`) and never imports them statically.

Families: `distractors` (Task-Relevant Distractors, 6 settings), `precondition` (Task-Precondition
Variation, 2), `ambiguity` (Visual State Ambiguity, 2), `geometry_scene` (Target Geometry
Variation, 12, placing the deformed objects of `vpro_assets.objects.deformed`).
"""
