"""Imported by the multiprocessing forkserver of :class:`navbench.pipeline.executor.LocalExecutor`
(its preload list) and by nothing else: the forkserver then dies with the command that started
it (``PR_SET_PDEATHSIG`` on Linux), so a ``kill -9`` of the command leaves no process behind.
Its children, the pool workers, die with it (see ``executor._init_worker``)."""

from navbench.pipeline.executor import die_with_parent

die_with_parent()
