def check_designs(cls, parameters, designs):
    return None
