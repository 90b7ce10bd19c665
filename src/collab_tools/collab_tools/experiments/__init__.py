"""The experiments layer shared by every package: one signature, one result schema, sweeps and plots.

Each package keeps one module per paper table or figure in ``<package>/experiments/`` and lists
them as :class:`~.api.Experiment` entries in that subpackage's ``EXPERIMENTS``; ``scripts/experiment``
finds them through :data:`~.registry.EXPERIMENT_PACKAGES` and runs them the same way:

    run(request: ExperimentRequest) -> ExperimentResult

``api`` defines those types and writes ``results.json`` and the experiment's report, outcome first
(:func:`~.api.write_results`);
``sweep`` is an experiment's loop (:class:`~.sweep.Steps`, ``ExperimentRequest.progress``: each finished
step checkpointed, skipped on ``--resume``) and runs a function over cases that way; ``progress`` draws
the bar (tqdm) or plain lines with elapsed time and ETA; ``checkpoint`` keeps ``RUN_DIR/run.json`` and
``RUN_DIR/partial/``; ``inputs`` turns ``--config``/``--set`` into the run's configuration directory;
``plots`` makes and saves figures (headless, titles and legends never clipped).
"""
