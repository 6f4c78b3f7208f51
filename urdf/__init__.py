"""Vehicle descriptions shipped with aiauv-pin (URDF files and the specs they are built from).

Installed as the data package ``aiauv_pin.urdf``; find files with
``importlib.resources.files("aiauv_pin.urdf")``.
"""
