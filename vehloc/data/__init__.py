"""CompCars-format data sets and the vehicle specifications table."""
