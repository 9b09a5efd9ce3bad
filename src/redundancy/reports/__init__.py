"""Reports: the lesson's tables and the audit, computed from the analyses and formatted."""
