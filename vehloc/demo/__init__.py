"""`vehloc-demo`: the whole paper on the embedded demo data, from the demo set to one report (both tables)."""
