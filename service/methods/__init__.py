"""The service's methods: the registry and one module per method family.

:mod:`.registry` is the table the API serves (name, params model, run
function, example); :mod:`.domain_schema` the JSON shape of a planar
domain; :mod:`.product`, :mod:`.triangulation`, :mod:`.quads` and
:mod:`.medial` the params models and run functions of each family.
"""
