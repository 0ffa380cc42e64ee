"""Workshop files of a design: one writer per format.

Every writer takes the design document (the content of ``design.json``, in
millimetres, built by :func:`design_document`), so all files agree with it
by construction. Writers go through :mod:`airmat.atomic`.
"""

from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``): ezdxf loads with the DXF writer only
__getattr__, __dir__, __all__ = attach(__name__, {
    "design_json": ["design_document", "write_design_json", "read_design_json"],
    "svg": ["write_svg"],
    "pdf": ["write_pdf", "pdf_bytes"],
    "dxf": ["write_dxf"],
    "cutting_list": ["write_cutting_list"],
    "rhino": ["write_3dm", "rhino_model", "lift_to_surface", "lift_to_face"],
    "retie_files": ["write_retie", "retie_document", "retie_figure"],
    "preview": ["write_preview", "preview_figure"],
})
