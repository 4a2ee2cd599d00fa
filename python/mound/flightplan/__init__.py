"""What a flight plan needs of the aircraft's flight over real ground, below both the
planner (plan: the sites' costs) and the missions (uav: the heights flown): the clearance
over a DEM and what climbing costs (terrain.py)."""
