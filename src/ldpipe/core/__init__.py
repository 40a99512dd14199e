"""The science core: one module or package per concept, named as the configuration names it."""
