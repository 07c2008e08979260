"""The start-kit entry: the package's planner, scheduler and executor as the League of Robot
Runners start kit's three Python components, and the kit built and run beside them.

- :mod:`~warehouse_phys.lorr.startkit.planner`, :mod:`~warehouse_phys.lorr.startkit.scheduler`,
  :mod:`~warehouse_phys.lorr.startkit.executor`: the entry's three parts over plain arrays
  (guided PIBT, the package's schedulers, the queued executor of square robots);
- :mod:`~warehouse_phys.lorr.startkit.tasks`: the kit's task manager (schedules taken at
  each round, errands counted where the robots stand);
- :mod:`~warehouse_phys.lorr.startkit.system`: the kit's simulation loop restated, so that
  ``simulate`` runs the entry by the kit's rules without the kit;
- :mod:`~warehouse_phys.lorr.startkit.adapters`: the three parts as the kit's
  ``pyMAPFPlanner``, ``pyTaskScheduler`` and ``pyExecutor`` (its ``MAPF`` types to arrays
  and back); :mod:`~warehouse_phys.lorr.startkit.install` writes the kit's three
  ``python/user_*/`` files that load them;
- :mod:`~warehouse_phys.lorr.startkit.build` builds the kit into a cache folder,
  :mod:`~warehouse_phys.lorr.startkit.runs` runs it (the entry, the kit's default entry)
  and reads what it reported.
"""
