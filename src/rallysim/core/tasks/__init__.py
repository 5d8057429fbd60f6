"""The tasks over the batched game: they turn a decision's ``Events`` into rewards, episode
ends and ``info``. The low-level return tasks (``simple_return``, ``humanlike_return``), the
two-player rally (``rally``) and its turn-based form (``turns``, ``turn_loop``).

The top of ``core``: a task reads its player kind's ``rallysim.players`` spec, and the turn loop
resolves policy names with ``rallysim.policies.registry``; nothing below imports a task."""
