"""MAVLink: the link to the vehicle (pymavlink) and the mission protocol. The only package
that imports pymavlink; it sets MAVLINK20=1 first, without which pymavlink speaks MAVLink 1
and message signing silently stays off."""

import os

os.environ["MAVLINK20"] = "1"
