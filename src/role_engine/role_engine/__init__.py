"""Role engine of the role-based collaboration subsystem (Akbari et al., RBC + GP inference)."""
