"""`wsbuild pkg create`: rendering the logic-free template folders of templates/pkg/
(`render`) and the license texts (`licenses`).
May use: workspace, errors.
"""
