"""The UAV mission: MAVLink mission items from a plan, mission files for ground stations,
and the MAVLink link that uploads them (mavlink/)."""
