"""The render worker, ``python -m reports.figures`` (started by
:class:`reports.figures.process.RenderProcess`): it answers render requests until stdin closes."""

from reports.figures.process import serve

serve()
