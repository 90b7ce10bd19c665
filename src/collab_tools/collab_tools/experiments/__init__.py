"""The experiments layer shared by every package: one signature, one result schema, sweeps and plots.

Each package keeps one module per paper table or figure in ``<package>/experiments/`` and lists
them as :class:`~.api.Experiment` entries in that subpackage's ``EXPERIMENTS``; ``scripts/experiment``
finds them through :data:`~.registry.EXPERIMENT_PACKAGES` and runs them the same way:

    run(request: ExperimentRequest) -> ExperimentResult

``api`` defines those types and writes ``results.json`` (:func:`~.api.write_results`);
``sweep`` runs a function over cases with progress lines; ``plots`` makes and saves figures
(headless, titles and legends never clipped).
"""
