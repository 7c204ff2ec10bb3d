"""The plan layer: an inspection plan's datums, regions and characteristics (GD&T) judged on a
registered part. ``plan`` holds what a plan says (read from TOML by engine.io.plan), ``regions``
which nominal and measured points belong to a region, ``features`` the geometry of a feature
(minimum zone, least-squares circle, sphere and cylinder, position), ``datums`` the datum
reference frames that place the part, ``characteristics`` the plan judged. It stands above the
registration, deviation and verdict maths it uses, and reads no file (import-linter contracts)."""
