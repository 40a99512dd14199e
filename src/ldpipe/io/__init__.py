"""Stage files: what each holds (``contracts``), how it is written and read (``datafile``), which
library files a stage depends on (``provenance``), and comparing two runs' files (``filediff``);
how every file ldpipe writes is put in place, whole or not at all (``atomic``)."""
