"""Small task definitions for the SGCM tests (plain dicts for ``parse_task``)."""


def small_task_data(rows=1, cols=3, colours=None, capacity=6, **sections) -> dict:
    """A parse_task dict for a small grid; ``colours`` maps name -> goal [row, col].

    Keyword sections (robots, cost, reward, utility, game, ...) are added as given.
    """
    colours = colours or {'red': [0, cols - 1]}
    data = {'grid': {'rows': rows, 'cols': cols, 'cell_capacity': capacity},
            'colours': {name: {'goal': list(goal), 'rgb': [0.5, 0.5, 0.5]} for name, goal in colours.items()}}
    data.update(sections)
    return data
