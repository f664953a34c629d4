"""Standard-format adapters: CPHD and SICD (through NGA's sarkit), the AFRL Gotcha phase history and the
geolocation that places the local scene frame on the Earth for them.

May import sarproc.product and sarproc.dsp (and quality); only the command line (cli) imports formats.
"""
