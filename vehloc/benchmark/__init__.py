"""The randomized localization benchmark: seeded cases drawn over the catalog's models, colours, poses,
cameras and light (`cases`), what of each car a camera can see (`visibility`), one case rendered and
localized against its truth (`runner`), and the per-group rates, tables and figures (`report`)."""
