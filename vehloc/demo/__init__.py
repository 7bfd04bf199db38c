"""`vehloc-demo`: the whole paper on the embedded demo data, from the demo set to one report (both tables). Its API
is its command line (`vehloc.demo.cli`)."""

__all__: list[str] = []
