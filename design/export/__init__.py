"""Workshop files of a design: one writer per format.

Every writer takes the design document (the content of ``design.json``, in
millimetres, built by :func:`design_document`), so all files agree with it
by construction. Writers go through :mod:`airmat.atomic`.
"""

from design.export.cutting_list import write_cutting_list
from design.export.design_json import design_document, read_design_json, write_design_json
from design.export.dxf import write_dxf
from design.export.preview import write_preview
from design.export.svg import write_svg

__all__ = ["design_document", "write_design_json", "read_design_json", "write_svg", "write_dxf",
           "write_cutting_list", "write_preview"]
