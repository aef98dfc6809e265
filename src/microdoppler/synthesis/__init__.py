"""The paper's model (eq. 1 thin-wire blades, eq. 2 body/blade/alpha), the radar, and the catalog of model extensions."""
