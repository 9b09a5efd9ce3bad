"""The interactive lab: simulation and controller, the browser page, a headless browser driver."""
