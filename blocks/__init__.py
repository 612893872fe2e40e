"""The block vocabulary and every built-in block type (`hapticgraph.blocks`)."""
from .vocabulary import Block, BlockDefinitionError, Buffer, External, In, Out, Param, State, block_equation, helper
from . import control, controllers, coupling, device, excitation, io, reed, sources, waveguide
from .massspring import cells, links


def builtin_types():
    """Every built-in block type, by type name."""
    found = {}
    for module in (waveguide, coupling, control, controllers, excitation, io, device, cells, links, reed, sources):
        for obj in vars(module).values():
            if isinstance(obj, type) and issubclass(obj, Block) and obj.__module__ == module.__name__:
                found[obj.type_name] = obj
    return found


__all__ = ["Block", "BlockDefinitionError", "Buffer", "External", "In", "Out", "Param", "State", "block_equation", "helper",
           "builtin_types"]
