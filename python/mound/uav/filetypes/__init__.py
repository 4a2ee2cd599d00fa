"""The mission file formats, one module each holding its FORMAT (a
mound.uav.mission_format.MissionFormat); mound.uav.mission_format's registry finds them
here. A new format is a new module here and nothing else."""
