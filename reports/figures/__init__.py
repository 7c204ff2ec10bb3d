"""Figures of an inspection: the tolerance-banded colour scale, 3D deviation maps (pyvista,
rendered off-screen), the 2D contour with magnified deviation whiskers and the histogram
(reportlab vector drawings). No Qt: the desktop app reuses the colour scale.

- :mod:`.colours`: the colour scale (bands across the tolerance zone and beyond) and the
  regions' colours;
- :mod:`.render`: the 3D maps, rendered with pyvista;
- :mod:`.process`: the figure server, :func:`~.render.render_3d` in a worker process
  (``python -m reports.figures``) or in this one;
- :mod:`.drawings`: the certificate's vector drawings (histogram, legend, colour bar, a view's
  overlay and callouts, the 2D contour map).
"""

from .colours import (ABOVE, BELOW, NO_REGION_RGB, RAMP, REGION_RGB, ZONE_STEPS, Band, Zone,
                      band_index, band_label, band_rgb, bands, ramp_rgb, region_colours,
                      surface_field, surface_rgb)
from .drawings import (TRIAD_RGB, colour_bar, contour_map, fmt_mm, histogram, legend,
                       map_flowable, map_overlay, nice_step, primitive_points,
                       template_polylines, whisker_factor)
from .process import InProcessRenderer, RenderError, RenderProcess
from .render import (CLUSTER_DIVISIONS, COLOURED_TRIANGLES, DISPLAY_TRIANGLES, MARKER_SHARE,
                     RENDER_SIZE, View, any_perpendicular, coloured_surface, display_surface,
                     face_on_direction, render_3d)

__all__ = [
    "ABOVE", "BELOW", "CLUSTER_DIVISIONS", "COLOURED_TRIANGLES", "DISPLAY_TRIANGLES", "MARKER_SHARE", "NO_REGION_RGB",
    "RAMP", "REGION_RGB", "RENDER_SIZE", "TRIAD_RGB", "ZONE_STEPS", "Band", "InProcessRenderer",
    "RenderError", "RenderProcess", "View", "Zone", "any_perpendicular", "band_index",
    "band_label", "band_rgb", "bands", "colour_bar", "coloured_surface", "contour_map",
    "display_surface", "surface_field", "surface_rgb",
    "face_on_direction", "fmt_mm", "histogram", "legend", "map_flowable", "map_overlay",
    "nice_step", "primitive_points", "ramp_rgb", "region_colours", "render_3d",
    "template_polylines", "whisker_factor",
]
