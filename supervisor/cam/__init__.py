"""From a greyscale depth map to roughing and finishing G-code (Borangiu et al., IFAC 2007, §3).

The grey level of each pixel is a height (black lowest, white highest), and the map is the
triangulated surface through the pixel centres; the finishing cutter is dropped on it
(vertices by the paper's grey-scale dilation, edges and facets as OpenCAMLib does); roughing
runs at constant-Z levels whose number and depths follow the grey-level gradient and the
largest axial depth the robust optimiser allows; finishing follows iso-parametric lines;
each path gets its (feed rate, spindle speed) from the robust milling optimiser; the
program is verified by sweeping the tool over the height field.

Modules, one idea each: :mod:`~supervisor.cam.depthmap` (reading the image),
:mod:`~supervisor.cam.cutter` (tool shapes), :mod:`~supervisor.cam.compensation` (grey-scale
dilation), :mod:`~supervisor.cam.dropcutter` and :mod:`~supervisor.cam.dropedges` (the cutter
dropped on the triangulated surface), :mod:`~supervisor.cam.levels` (the gradient rule),
:mod:`~supervisor.cam.contours` (marching squares to polygons),
:mod:`~supervisor.cam.roughing` (offset rings per level),
:mod:`~supervisor.cam.finishing` (iso-parametric lines, scallop height),
:mod:`~supervisor.cam.feeds` (setpoints per level from the optimiser),
:mod:`~supervisor.cam.arcs` (one-quadrant arcs), :mod:`~supervisor.cam.program` (the G-code
writer), :mod:`~supervisor.cam.motion` (reading the program back),
:mod:`~supervisor.cam.verify` (material-removal simulation) and :mod:`~supervisor.cam.job`
(the whole chain).
"""
