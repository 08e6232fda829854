"""Scene generators: plug-ins of the toolkit, one module per generator family.

Each module registers its generators with `vpro_assets.scene.plugins.register`; the toolkit loads
the modules by name (`vpro_assets.scene.plugins.FAMILY_MODULES`) and never imports them statically.

Families: `distractors` (Task-Relevant Distractors, 6 settings; choice rules in `distractor_choice`,
fixture-only goals in `fixture_goal`), `precondition` (Task-Precondition Variation, 2),
`ambiguity` (Visual State Ambiguity, 2), `geometry_scene` (Target Geometry Variation, 12, placing
the deformed objects of `vpro_assets.objects.deformed`). A case's variant
(`vpro_assets.benchmark.variants`) reaches its generator through the case's parameters.
"""
